"""The MX (2.0), XC335-T332 and RH-P12-RN(A) tables against the facts of their sources, written out
here: addresses and sizes from the model files (dynamixel-sdk wheel; dynamixel_hardware_interface for
the XC335), units, modes and initial values from the e-Manual pages (dxl/mx/mx-28-2, mx-64-2,
mx-106-2; platform/rh_p12_rn_a)."""
import math

import pytest

from dynamixel_handler.control_table import P, X, known_models, model_by_number

MX_28, MX_64, MX_106, XC335, RH_P12_RN_A = 30, 311, 321, 1700, 35074


def addresses(number: int, *names: str) -> list[tuple[int, int]]:
    model = model_by_number(number)
    return [(model.item(n).address, model.item(n).size) for n in names]


@pytest.mark.parametrize("number,name,family", [
    (MX_28, "MX-28(2.0)", X), (MX_64, "MX-64(2.0)", X), (MX_106, "MX-106(2.0)", X),
    (XC335, "XC335-T332", X), (RH_P12_RN_A, "RH-P12-RN(A)", P),
])
def test_recognised_with_name_and_family(number, name, family):
    model = model_by_number(number)
    assert (model.name, model.family) == (name, family)
    assert model in known_models()


def test_mx_items_are_the_x_table_with_an_acceleration_limit():
    for number in (MX_28, MX_64, MX_106):
        assert addresses(number, "torque_enable", "goal_velocity", "goal_position", "present_position",
                         "present_velocity", "acceleration_limit", "bus_watchdog", "shutdown") == [
            (64, 1), (104, 4), (116, 4), (132, 4), (128, 4), (40, 4), (98, 1), (63, 1)]
        model = model_by_number(number)
        assert model.item("acceleration_limit").eeprom and not model.item("torque_enable").eeprom
        # the MX (2.0) pages list neither Startup Configuration nor Backup Ready nor external ports
        assert not any(model.has(n) for n in ("startup_configuration", "backup_ready", "external_port_mode_1"))
        assert model.external_ports == ()


def test_mx_28_has_no_current_sensing():
    model = model_by_number(MX_28)
    assert addresses(MX_28, "present_load") == [(126, 2)]
    assert not any(model.has(n) for n in ("current_limit", "goal_current", "present_current"))
    assert math.isnan(model.current_ma_per_pulse)
    assert model.operating_modes == (1, 3, 4, 16)  # velocity, position, extended position, PWM
    assert model.modes == {"velocity", "position", "ex_position", "pwm"}
    assert model.mode_name(0) is None and model.mode_name(16) == "pwm"


def test_mx_64_and_106_have_current_and_every_x_mode():
    for number in (MX_64, MX_106):
        model = model_by_number(number)
        assert addresses(number, "current_limit", "goal_current", "present_current") == [(38, 2), (102, 2), (126, 2)]
        assert model.current_ma_per_pulse == pytest.approx(3.36)
        assert model.modes == X.modes and model.operating_modes == (0, 1, 3, 4, 5, 16)


def test_mx_units_baud_rates_and_blocks():
    for number in (MX_28, MX_64, MX_106):
        model = model_by_number(number)
        assert model.position_deg_per_pulse == pytest.approx(360 / 4096)
        assert model.position_zero_pulse == 2048
        assert model.velocity_deg_s_per_pulse == pytest.approx(0.229 * 6)
        assert model.pwm_percent_per_pulse == pytest.approx(100 / 885)
        assert dict(model.baud_rates) == {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000, 4: 2_000_000,
                                          5: 3_000_000, 6: 4_000_000, 7: 4_500_000}
        assert model.indirect == ((168, 224, 28), (578, 634, 28))
        assert model.table_size == 662


@pytest.mark.parametrize("number,velocity_limit,current_limit", [
    (MX_28, 380, None), (MX_64, 435, 1941), (MX_106, 360, 2047)])
def test_mx_factory_values(number, velocity_limit, current_limit):
    factory = model_by_number(number).factory
    assert factory["velocity_limit"] == velocity_limit
    assert factory.get("current_limit") == current_limit
    assert (factory["acceleration_limit"], factory["max_voltage_limit"], factory["min_voltage_limit"]) == (32767, 160, 95)
    assert (factory["velocity_i_gain"], factory["velocity_p_gain"], factory["position_p_gain"]) == (1920, 100, 850)
    assert (factory["shutdown"], factory["moving_threshold"], factory["temperature_limit"]) == (52, 10, 80)


def test_xc335_is_the_xc330_table_with_the_xm335_blocks():
    model = model_by_number(XC335)
    xc330 = model_by_number(1220)  # XC330-T288
    # its model file (xc335_t332.model): the XC330 rows but Startup Configuration in 2 bytes and no Backup Ready
    expected = {n: (i.address, i.size) for n, i in xc330.items.items() if n != "backup_ready"}
    expected["startup_configuration"] = (60, 2)
    assert {n: (i.address, i.size) for n, i in model.items.items()} == expected
    assert addresses(XC335, "pwm_slope", "startup_configuration", "present_current") == [(62, 1), (60, 2), (126, 2)]
    assert model.current_ma_per_pulse == 1.0
    assert model.indirect == ((168, 224, 28),) and model.table_size == 252
    assert max(model.baud_rates) == 6 and model.baud_rates[6] == 4_000_000
    assert model.modes == X.modes


def test_rh_p12_rn_a_is_the_p_table_with_its_stroke_and_modes():
    model = model_by_number(RH_P12_RN_A)
    assert addresses(RH_P12_RN_A, "torque_enable", "goal_current", "goal_velocity", "profile_velocity",
                     "goal_position", "present_current", "present_velocity", "present_position",
                     "external_port_data_1", "max_position_limit") == [
        (512, 1), (550, 2), (552, 4), (560, 4), (564, 4), (574, 2), (576, 4), (580, 4), (600, 2), (48, 4)]
    assert not model.has("drive_mode") and not model.has("startup_configuration")
    assert model.operating_modes == (0, 5)
    assert model.modes == {"current", "cur_position"}  # not P's: the gripper's own
    assert (model.position_min_pulse, model.position_max_pulse, model.position_zero_pulse) == (0, 1150, 0)
    assert model.position_deg_per_pulse == pytest.approx(0.088, abs=1e-3)
    assert model.velocity_deg_s_per_pulse == pytest.approx(0.01 * 6)
    assert model.current_ma_per_pulse == 1.0
    assert model.pwm_percent_per_pulse == pytest.approx(100 / 2009)
    assert model.baud_rates[9] == 10_500_000
    assert model.indirect == ((168, 634, 128),)
    assert model.external_ports == (1, 2, 3, 4)


def test_rh_p12_rn_a_factory_values():
    factory = model_by_number(RH_P12_RN_A).factory
    assert factory["operating_mode"] == 5  # current-based position from the box
    assert (factory["current_limit"], factory["velocity_limit"], factory["acceleration_limit"]) == (1984, 2970, 3447)
    assert (factory["min_position_limit"], factory["max_position_limit"]) == (0, 1150)
    assert (factory["moving_threshold"], factory["shutdown"], factory["max_voltage_limit"]) == (80, 52, 350)
    assert "position_p_gain" not in factory  # the page gives "-"


def test_other_models_keep_their_family_modes():
    for number in (1020, 2020, 54025, 54024):
        model = model_by_number(number)
        assert model.modes == model.family.modes and not model.own_modes


def test_the_x430_models_without_a_current_sensor_have_the_four_modes_of_their_firmware():
    """XL430-W250, XC430-W150/W240, 2XL430-W250, 2XC430-W250 (e-Manual "Operating Mode"): velocity,
    position, extended position and PWM; no current nor current-based position control."""
    for number in (1060, 1070, 1080, 1090, 1160):
        model = model_by_number(number)
        assert model.own_modes and model.operating_modes == (1, 3, 4, 16), model.name
        assert model.modes == {"velocity", "position", "ex_position", "pwm"}, model.name


def test_rh_p12_rn_old_firmware_is_the_old_pro_table_without_what_it_lacks():
    """RH-P12-RN (model 35073, e-Manual platform/rh_p12_rn): the old PRO "-R" addresses, no Homing
    Offset and no velocity gains but Position D / I Gain, its own units and two modes."""
    model = model_by_number(35073)
    assert (model.name, model.family.name, model.layout) == ("RH-P12-RN", "PRO", "OLD_PRO")
    assert addresses(35073, "torque_enable", "position_d_gain", "position_i_gain", "position_p_gain",
                     "goal_position", "goal_velocity", "goal_current", "profile_acceleration",
                     "present_position", "present_current", "status_return_level") == [
        (562, 1), (590, 2), (592, 2), (594, 2), (596, 4), (600, 4), (604, 2), (606, 4), (611, 4), (621, 2), (891, 1)]
    assert not any(model.has(n) for n in ("homing_offset", "velocity_i_gain", "velocity_p_gain", "goal_pwm"))
    assert model.modes == {"current", "cur_position"} and model.operating_modes == (0, 5)
    assert model.current_ma_per_pulse == pytest.approx(4.02)
    assert model.velocity_deg_s_per_pulse == pytest.approx(0.114 * 6)
    assert model.acceleration_deg_ss_per_pulse == pytest.approx(214.577 / 10)
    assert math.isnan(model.pwm_percent_per_pulse)
    assert (model.position_min_pulse, model.position_max_pulse) == (0, 1150)
    assert model.indirect == ((49, 634, 256),)
    factory = model.factory
    assert (factory["operating_mode"], factory["current_limit"], factory["velocity_limit"]) == (5, 820, 100)
    assert (factory["acceleration_limit"], factory["max_position_limit"], factory["shutdown"]) == (255, 1150, 48)


def test_virtual_servos_refuse_what_the_hardware_refuses():
    """The virtual bus from these tables: a gripper refuses a goal beyond its position limits in
    current-based position mode (an X servo there does not: multi-turn), the MX-28(2.0) refuses the
    current modes and the gripper every mode but its two."""
    from dynamixel_handler.protocol import servo as wire
    from dynamixel_handler.sim.servo import VirtualServo

    def error(number: int, item: str, value: int) -> int:
        servo = VirtualServo(number, 1, lambda: 0.0)
        spec = servo.model.item(item)
        return servo.check_write(spec.address, spec.to_bytes(value))[0]

    for number in (RH_P12_RN_A, 35073):
        assert error(number, "goal_position", 1151) == wire.ERR_DATA_LIMIT
        assert error(number, "goal_position", 740) == wire.ERR_NONE
        assert error(number, "operating_mode", 3) == wire.ERR_DATA_RANGE
        assert error(number, "operating_mode", 0) == wire.ERR_NONE
    assert error(MX_28, "operating_mode", 0) == wire.ERR_DATA_RANGE
    assert error(MX_28, "operating_mode", 5) == wire.ERR_DATA_RANGE
    assert error(MX_28, "operating_mode", 16) == wire.ERR_NONE
    x = VirtualServo(MX_64, 1, lambda: 0.0)
    x.write("operating_mode", 5)
    assert x.check_write(116, (5000).to_bytes(4, "little"))[0] == wire.ERR_NONE
