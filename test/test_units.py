"""Pulse <-> physical-unit conversion, byte encoding and bit fields."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynamixel_handler import units
from dynamixel_handler.control_table import known_models, model_by_number

XM430, XL330, XL430, XM540 = (model_by_number(n) for n in (1020, 1200, 1060, 1120))
PH54, PRO_RA, H54, H42 = (model_by_number(n) for n in (2020, 54025, 54024, 51200))


def to_unit(model, item, pulse):
    return float(units.pulse_to_unit([model], item, [pulse])[0])


def to_pulse(model, item, value):
    return int(units.unit_to_pulse([model], item, [value])[0])


@pytest.mark.parametrize("model,item,pulse,expected", [
    (XM430, "present_position", 2048, 0.0),
    (XM430, "present_position", 3072, 90.0),
    (XM430, "goal_position", 0, -180.0),
    (XM430, "max_position_limit", 4095, 179.912109375),
    (XM430, "homing_offset", 1024, 90.0),          # no 2048 offset on homing offset
    (PH54, "present_position", 501923, 180.0),
    (PH54, "present_position", -501923, -180.0),
    (PRO_RA, "goal_position", 501923, 180.0),
    (H54, "present_position", 250961, 180.0),
    (H42, "present_position", -151875, -180.0),
    (XM430, "present_current", 100, 269.0),
    (XL330, "present_current", 1, 1.0),
    (PH54, "goal_current", 100, 100.0),
    (H54, "present_current", 2048, 33000.0),
    (H42, "goal_current", 2048, 8250.0),            # old PRO Goal Torque shares the mA scale
    (XM430, "present_velocity", 1, 1.374),
    (XM430, "velocity_limit", 100, 137.4),
    (PH54, "present_velocity", 100, 6.0),
    (H54, "present_velocity", 1, 0.00199234 * 6),
    (XM430, "profile_acceleration", 1, 21.4577),
    (PH54, "profile_acceleration", 10, 1.0),
    (XM430, "goal_pwm", 885, 100.0),
    (PH54, "present_pwm", -2009, -100.0),
    (XM430, "present_input_voltage", 120, 12.0),
    (XM430, "present_temperature", 45, 45.0),
    (XM430, "return_delay_time", 250, 500.0),
    (XM430, "bus_watchdog", 5, 100.0),
    (XM430, "realtime_tick", 1500, 1.5),
    (XL430, "present_load", -1000, -100.0),
    (XM430, "position_p_gain", 800, 800.0),         # gains stay raw
])
def test_hand_computed_values(model, item, pulse, expected):
    assert to_unit(model, item, pulse) == pytest.approx(expected)


def test_mixed_models_in_one_call():
    models = [XM430, XL330, PH54, H54, XL430]
    got = units.pulse_to_unit(models, "present_current", np.array([100, 100, 100, 100, 100]))
    assert got.dtype == np.float64
    np.testing.assert_allclose(got[:4], [269.0, 100.0, 100.0, 100 * 33000 / 2048])
    assert math.isnan(got[4])  # XL430 has no current sensor
    pos = units.pulse_to_unit(models[:4], "present_position", [3072, 2048, 501923, -250961])
    np.testing.assert_allclose(pos, [90.0, 0.0, 180.0, -180.0])
    back = units.unit_to_pulse(models[:4], "goal_position", [90.0, 0.0, 180.0, -180.0])
    assert back.dtype == np.int64
    assert back.tolist() == [3072, 2048, 501923, -250961]


def test_pwm_is_nan_on_old_pro():
    assert math.isnan(units.pulse_to_unit([H54], "present_pwm", [5])[0])


def _sample_pulses(item):
    lo, hi = item.min_raw, item.max_raw
    picks = {lo, hi, lo + 1, hi - 1, (lo + hi) // 2, 0 if lo <= 0 else lo, 1, 2048, 4095}
    return [p for p in sorted(picks) if lo <= p <= hi]


@pytest.mark.parametrize("model", known_models(), ids=lambda m: m.name)
def test_round_trip_every_item_of_every_model(model):
    for name, item in model.items.items():
        pulses = np.array(_sample_pulses(item), dtype=np.int64)
        models = [model] * len(pulses)
        values = units.pulse_to_unit(models, name, pulses)
        if np.isnan(values).any():
            pytest.fail(f"{model.name} {name} has no unit")
        assert units.unit_to_pulse(models, name, values).tolist() == pulses.tolist(), name


def test_rounding_is_to_nearest_pulse():
    assert to_pulse(XM430, "goal_current", 2.69 * 10.4) == 10
    assert to_pulse(XM430, "goal_current", 2.69 * 10.6) == 11
    assert to_pulse(XM430, "goal_current", -2.69 * 10.6) == -11
    assert to_pulse(XM430, "goal_position", 0.04) == 2048
    assert to_pulse(XM430, "goal_position", 0.05) == 2049


def test_clips_instead_of_wrapping():
    # 4-byte signed goal position: a huge angle saturates, it must not wrap negative.
    assert to_pulse(XM430, "goal_position", 1e12) == 2 ** 31 - 1
    assert to_pulse(XM430, "goal_position", -1e12) == -(2 ** 31)
    # 2-byte signed goal current.
    assert to_pulse(XM430, "goal_current", 1e6) == 32767
    assert to_pulse(XM430, "goal_current", -1e6) == -32768
    # Unsigned items floor at zero and top out at their size.
    assert to_pulse(XM430, "profile_velocity", -50.0) == 0
    assert to_pulse(XM430, "return_delay_time", 1e6) == 255
    assert to_pulse(PH54, "present_input_voltage", 1e9) == 65535
    # The clipped value still encodes without error.
    item = XM430.item("goal_current")
    assert units.decode(item, units.encode(item, [to_pulse(XM430, "goal_current", 1e6)])).tolist() == [32767]


def test_a_value_at_the_edge_of_float_range_saturates_without_a_runtime_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warning would land in the user's log
        assert to_pulse(XM430, "goal_position", 1.7e308) == 2 ** 31 - 1
        assert to_pulse(XM430, "goal_position", -1.7e308) == -(2 ** 31)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_refuses_non_finite_values_naming_the_index(bad):
    with pytest.raises(ValueError, match="index 2"):
        units.unit_to_pulse([XM430, XM430, XM430], "goal_position", [0.0, 1.0, bad])


def test_refuses_models_without_the_item():
    with pytest.raises(ValueError, match="index 1"):
        units.unit_to_pulse([XM430, H54], "goal_pwm", [10.0, 10.0])
    with pytest.raises(ValueError, match="XL430"):
        units.unit_to_pulse([XL430], "goal_current", [10.0])


def test_length_mismatch_is_an_error_and_scalars_broadcast():
    with pytest.raises(ValueError):
        units.pulse_to_unit([XM430, XM430], "present_position", [1, 2, 3])
    np.testing.assert_allclose(units.pulse_to_unit([XM430, PH54], "present_velocity", 1),
                               [1.374, 0.06])


def test_results_are_fresh_arrays():
    first = units.pulse_to_unit([XM430], "present_position", [2048])
    first[0] = 123.0
    assert units.pulse_to_unit([XM430], "present_position", [2048])[0] == 0.0


def test_quantity_of():
    assert units.quantity_of("goal_position") == "position"
    assert units.quantity_of("homing_offset") == "position_offset"
    assert units.quantity_of("moving_threshold") == "velocity"
    assert units.quantity_of("acceleration_limit") == "acceleration"
    assert units.quantity_of("velocity_p_gain") == "raw"
    assert units.UNIT_OF_QUANTITY["acceleration"] == "deg/s^2"


# ---- bytes ---------------------------------------------------------------------------------

def test_encode_decode_little_endian_with_sign():
    pos = XM430.item("goal_position")
    raw = units.encode(pos, [-1, 3072])
    assert raw == b"\xff\xff\xff\xff\x00\x0c\x00\x00"
    assert units.decode(pos, raw, 2).tolist() == [-1, 3072]
    cur = XM430.item("present_current")
    assert units.decode(cur, b"\xff\xff").tolist() == [-1]
    lim = XM430.item("current_limit")
    assert units.decode(lim, b"\xff\xff").tolist() == [65535]
    assert units.decode(pos, np.array([0, 8, 0, 0], dtype=np.uint8)).tolist() == [2048]
    assert units.decode(XM430.item("id"), b"\x07").dtype == np.int64


def test_encode_refuses_out_of_range_and_fractions():
    with pytest.raises(ValueError, match="index 1"):
        units.encode(XM430.item("goal_current"), [0, 40000])
    with pytest.raises(ValueError):
        units.encode(XM430.item("profile_velocity"), [-1])
    with pytest.raises(ValueError):
        units.encode(XM430.item("goal_position"), [1.5])


def test_decode_needs_enough_bytes():
    with pytest.raises(ValueError):
        units.decode(XM430.item("goal_position"), b"\x00\x01", 1)


# ---- bit fields ------------------------------------------------------------------------------

def test_hardware_error_bits():
    got = units.decode_hardware_error([0b100101, 0, 0b000010])
    assert got["input_voltage"].tolist() == [True, False, False]
    assert got["overheating"].tolist() == [True, False, False]
    assert got["overload"].tolist() == [True, False, False]
    assert got["motor_hall_sensor"].tolist() == [False, False, True]
    assert not got["motor_encoder"].any() and not got["electrical_shock"].any()


def test_shutdown_round_trip_and_default():
    flags = units.decode_shutdown(52)  # X factory default: overheating, electrical shock, overload
    assert {k for k, v in flags.items() if v[0]} == {
        "overheating_error", "electrical_shock_error", "overload_error"}
    assert units.encode_shutdown(**{k: bool(v[0]) for k, v in flags.items()}) == 52
    assert units.encode_shutdown(input_voltage_error=True, motor_encoder_error=True) == 0b1001


def test_moving_status():
    got = units.decode_moving_status([0x33, 0x08, 0x10, 0x20])
    assert got["in_position"].tolist() == [True, False, False, False]
    assert got["profile_ongoing"].tolist() == [True, False, False, False]
    assert got["following_error"].tolist() == [False, True, False, False]
    assert got["velocity_profile"] == ["trapezoidal", "none", "rectangular", "triangular"]


def test_drive_mode_round_trip():
    value = units.encode_drive_mode(reverse_mode=True, profile_configuration="time_based",
                                    torque_on_by_goal_update=True)
    assert value == 0b1101
    got = units.decode_drive_mode(value)
    assert got["reverse_mode"][0] and got["torque_on_by_goal_update"][0]
    assert got["profile_configuration"] == ["time_based"]
    assert units.decode_drive_mode(0)["profile_configuration"] == ["velocity_based"]
    with pytest.raises(ValueError):
        units.encode_drive_mode(profile_configuration="fast")


def test_startup_configuration():
    ram_restore, torque_on = units.decode_startup_configuration([0, 1, 2, 3])
    assert ram_restore.tolist() == [False, False, True, True]
    assert torque_on.tolist() == [False, True, False, True]
    assert units.encode_startup_configuration(ram_restore=True, startup_torque_on=True) == 3


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from([1020, 1120, 2020, 54024, 1060, 1200]), min_size=1, max_size=8, unique=True),
       st.sampled_from(["present_position", "present_velocity", "present_current", "present_input_voltage",
                        "goal_position", "present_pwm"]),
       st.data())
def test_the_tables_kept_conversion_equals_pulse_to_unit(numbers, item, data):
    """The servo table converts with an offset and scale kept per item until its servos or models
    change: the values equal ``pulse_to_unit``'s, NaN where unknown, also after a model is
    replaced and a servo removed."""
    from dynamixel_handler.servo.table import ServoTable

    table = ServoTable()
    for dxl_id, number in enumerate(numbers, start=1):
        table.add(dxl_id, model_by_number(number))

    def check() -> None:
        n = len(table)
        pulses = np.array(data.draw(st.lists(st.integers(-4000, 4000), min_size=n, max_size=n)), dtype=np.int64)
        known = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)
        table.store(item, np.flatnonzero(known), pulses[known], 0.0)
        stored, seen = table.arrays(item)
        want = units.pulse_to_unit(table.models, item, stored)
        want[~seen] = np.nan
        np.testing.assert_array_equal(table.units(item), want)

    check()
    table.add(1, model_by_number(data.draw(st.sampled_from([1020, 2020, 1060]))))  # the model replaced
    check()
    if len(table) > 1:
        table.remove(table.ids[-1])
        check()
