"""The DYNAMIXEL-Y family and its twelve models against the ROBOTIS e-Manual (docs/en/dxl/y/...):
addresses, RAM items below 512, units, factory values, the error codes and what the handler makes
of them, and the virtual servo that simulates them. Expected numbers are written out from the
manual pages, not taken from the product's tables."""
from __future__ import annotations

import time

import numpy as np
import pytest

from dynamixel_handler import units
from dynamixel_handler.config import SCHEMA
from dynamixel_handler.control_table import FAMILIES, SERIES, Model, family_named, family_titled, known_models, model_by_number
from dynamixel_handler.protocol import servo as p
from dynamixel_handler.servo import error_state
from dynamixel_handler.servo.table import ServoTable
from dynamixel_handler.sim.servo import VirtualServo

NAMES = {
    4000: "YM070-210-M001-RH", 4010: "YM070-210-B001-RH", 4020: "YM070-210-R051-RH", 4030: "YM070-210-R099-RH",
    4040: "YM070-210-A051-RH", 4050: "YM070-210-A099-RH", 4120: "YM080-230-M001-RH", 4130: "YM080-230-B001-RH",
    4140: "YM080-230-R051-RH", 4150: "YM080-230-R099-RH", 4160: "YM080-230-A051-RH", 4170: "YM080-230-A099-RH",
}
Y_MODELS = [model_by_number(n) for n in NAMES]
ERROR_CLEAR = bytes([0x02, 0x45, 0x52, 0x43, 0x4C])
# e-Manual control table: name -> (address, size, EEPROM)
ADDRESSES = {
    "model_number": (0, 2, True), "id": (7, 1, True), "bus_watchdog": (8, 2, False), "baud_rate": (12, 1, True),
    "return_delay_time": (13, 1, True), "status_return_level": (15, 1, False), "drive_mode": (32, 1, True),
    "operating_mode": (33, 1, True), "startup_configuration": (34, 1, True), "homing_offset": (52, 4, True),
    "inverter_temperature_limit": (56, 1, True), "temperature_limit": (57, 1, True),
    "max_voltage_limit": (60, 2, True), "min_voltage_limit": (62, 2, True), "current_limit": (66, 2, True),
    "velocity_limit": (72, 4, True), "max_position_limit": (76, 4, True), "min_position_limit": (84, 4, True),
    "controller_state": (152, 1, False), "error_code": (153, 1, False), "hybrid_save": (170, 1, False),
    "velocity_i_gain": (212, 4, False), "position_p_gain": (232, 4, False), "profile_velocity": (244, 4, False),
    "torque_enable": (512, 1, False), "led": (513, 1, False), "goal_current": (526, 2, False),
    "goal_velocity": (528, 4, False), "goal_position": (532, 4, False), "moving_status": (541, 1, False),
    "present_current": (546, 2, False), "present_velocity": (548, 4, False), "present_position": (552, 4, False),
    "present_input_voltage": (568, 2, False), "present_inverter_temperature": (570, 1, False),
    "present_temperature": (571, 1, False), "backup_ready": (919, 1, False),
}


def test_the_family_is_data():
    y = family_named("Y")
    assert "Y" in SERIES and y in FAMILIES and family_titled(" y ") is y
    assert y.modes == {"current", "velocity", "position"}
    assert not y.series_topics and not y.used_by_default and not y.x_table
    assert y.error_codes is not None and y.error_codes.item == "error_code"
    assert model_by_number(y.dummy_model).family is y
    assert any(param.name == "init/used_servo_series.Y" and param.default is False for param in SCHEMA)


@pytest.mark.parametrize("number", list(NAMES))
def test_every_model_is_known_with_its_name(number):
    model = model_by_number(number)
    assert (model.name, model.series, model.layout) == (NAMES[number], "Y", "Y")
    assert model.operating_modes == (0, 1, 3)
    assert dict(model.mode_values) == {"current": 0, "velocity": 1, "position": 3}
    assert not model.has("hardware_error_status") and not model.has("shutdown")
    assert not model.has("baud_rate_bus") and not model.has("present_motor_temperature")


@pytest.mark.parametrize("model", Y_MODELS, ids=lambda m: m.name)
def test_addresses_and_memory_areas(model: Model):
    for name, (address, size, eeprom) in ADDRESSES.items():
        it = model.item(name)
        assert (it.address, it.size, it.eeprom) == (address, size, eeprom), name
    assert model.item("bus_watchdog").signed  # reads -1 once tripped
    spans = sorted((it.address, it.address + it.size, n) for n, it in model.items.items())
    for (_, end, n0), (start, _, n1) in zip(spans, spans[1:]):
        assert end <= start, f"{n0} overlaps {n1}"
    assert model.indirect == ((256, 634, 128),) and model.table_size == 920
    assert model.baud_rates[9] == 10_500_000 and model.baud_rates[1] == 57_600


def test_units_per_pulse():
    y = model_by_number(4170)

    def unit(item, raw):
        return float(units.pulse_to_unit([y], item, [raw])[0])
    assert unit("present_position", 262_144) == pytest.approx(180.0)
    assert unit("goal_position", -131_072) == pytest.approx(-90.0)
    assert unit("present_velocity", 100) == pytest.approx(6.0)        # 1 rev/min
    assert unit("profile_acceleration", 6) == pytest.approx(6.0)      # 60 rev/min^2 = 6 deg/s^2
    assert unit("present_current", 123) == pytest.approx(1230.0)      # 0.01 A
    assert unit("present_pwm", 1000) == pytest.approx(100.0)          # 0.1 %
    assert unit("present_input_voltage", 2412) == pytest.approx(24.12)
    assert unit("max_voltage_limit", 320) == pytest.approx(32.0)
    assert unit("bus_watchdog", 100) == pytest.approx(2000.0)         # the manual's example
    assert unit("return_delay_time", 250) == pytest.approx(500.0)
    assert int(units.unit_to_pulse([y], "goal_position", [45.0])[0]) == 65_536


@pytest.mark.parametrize("number,values", [
    (4000, {"velocity_limit": 550_000, "acceleration_limit": 44_000, "temperature_limit": 80,
            "electronic_gearratio_numerator": 1, "brake_delay": 0, "moving_threshold": 1000}),
    (4010, {"brake_delay": 20, "goal_update_delay": 200, "normal_excitation_voltage": 30}),
    (4020, {"velocity_limit": 3_921, "electronic_gearratio_numerator": 51, "in_position_threshold": 19}),
    (4120, {"velocity_limit": 310_000, "profile_acceleration": 24_800}),
    (4170, {"velocity_limit": 2_020, "profile_velocity": 2_020, "acceleration_limit": 161, "temperature_limit": 60,
            "inverter_temperature_limit": 80, "current_limit": 2_080, "pwm_limit": 1_000, "max_voltage_limit": 320,
            "min_voltage_limit": 160, "max_position_limit": 262_144, "min_position_limit": -262_144,
            "velocity_i_gain": 2_446_559, "position_p_gain": 6_283_185, "electronic_gearratio_numerator": 99}),
])
def test_factory_values_match_the_pages(number, values):
    factory = model_by_number(number).factory
    assert {k: factory[k] for k in values} == values


@pytest.mark.parametrize("model", Y_MODELS, ids=lambda m: m.name)
def test_factory_values_fit_their_items(model: Model):
    for name, value in model.factory.items():
        it = model.item(name)
        assert it.min_raw <= value <= it.max_raw, name
    assert model.position_min_pulse <= model.factory["min_position_limit"] < model.factory["max_position_limit"]


def _table(*numbers: int) -> ServoTable:
    table = ServoTable()
    for i, number in enumerate(numbers, start=1):
        table.add(i, model_by_number(number))
    return table


def test_error_codes_as_the_error_state():
    table = _table(1020, 4170, 4000, 4010)  # an X beside three Y
    table.store("hardware_error_status", np.array([0]), np.array([0x04]), 0.0)  # X: overheating bit
    # overload, bus watchdog error, battery warning
    table.store("error_code", np.array([1, 2, 3]), np.array([5, 18, 9]), 0.0)
    bits = error_state.hardware_bits(table)
    assert bits.tolist() == [0x04, 0x20, 0, 0]
    assert error_state.in_error(table).tolist() == [True, True, True, False]  # a warning is no error
    y = model_by_number(4170)
    assert error_state.describe(y, 5) == "error code 5 (Overload Error)"
    assert error_state.describe(model_by_number(1020), 0x24) == "0x24"
    assert error_state.error_item(y) == "error_code"
    assert error_state.codes_by_position(table)[2] == "error code 18 (Bus Watchdog Error)"
    decoded = units.decode_hardware_error(bits)
    assert decoded["overload"].tolist() == [False, True, False, False]


def test_every_error_code_of_the_manual():
    codes = family_named("Y").error_codes
    assert codes is not None
    assert {c.value for c in codes.codes} == {1, 2, 3, 4, 5, 7, 9, 10, 11, 12, 13, 14, 15, 17, 18, 19, 20}
    assert {c.value for c in codes.codes if c.clearable} == {1, 2, 3, 4, 5, 17, 18, 19, 20}
    assert {c.value for c in codes.codes if not c.torque_off} == {9, 17, 18, 19, 20}
    assert codes.clear_params == ERROR_CLEAR
    assert codes.is_error(99) and codes.name(99) == "error code 99"  # unknown: an error, by number


def test_virtual_y_servo_is_unboxed_as_the_page_says():
    servo = VirtualServo(4170, 3, time.monotonic)
    assert servo.read("model_number") == 4170 and servo.read("id") == 3
    assert servo.read("velocity_limit") == 2_020 and servo.read("baud_rate") == 1
    assert servo.read("operating_mode") == 3 and servo.read("error_code") == 0
    assert servo.read("present_input_voltage") == 2400  # 24 V in 0.01 V
    assert servo.host_write(33, bytes([4]), time.monotonic()) == p.ERR_DATA_RANGE  # no extended position
    assert servo.host_write(64, (1001).to_bytes(2, "little"), time.monotonic()) == p.ERR_DATA_RANGE
    assert servo.host_write(64, (1000).to_bytes(2, "little"), time.monotonic()) == p.ERR_NONE
    assert servo.host_write(153, bytes([0]), time.monotonic()) == p.ERR_ACCESS  # Error Code is read-only


def test_virtual_y_servo_error_code_and_clear():
    servo = VirtualServo(4000, 1, time.monotonic)
    now = time.monotonic()
    assert servo.host_write(512, bytes([1]), now) == p.ERR_NONE
    servo.write("error_code", 4)  # motor overheating: torque off, alert, torque on refused
    assert servo.read("torque_enable") == 0 and servo.error_flags(0) & p.ALERT_BIT
    assert servo.host_write(512, bytes([1]), now) == p.ERR_RESULT_FAIL
    assert servo.clear(bytes([0x02, 0, 0, 0, 0]), now) != p.ERR_NONE  # a wrong key clears nothing
    assert servo.read("error_code") == 4
    assert servo.clear(ERROR_CLEAR, now) == p.ERR_NONE
    assert servo.read("error_code") == 0 and servo.error_flags(0) == 0
    assert servo.host_write(512, bytes([1]), now) == p.ERR_NONE
    servo.write("error_code", 11)  # magnet error: the clear cannot clear it
    assert servo.clear(ERROR_CLEAR, now) == p.ERR_RESULT_FAIL and servo.read("error_code") == 11


def test_x_servos_keep_their_error_bits():
    x = VirtualServo(1020, 1, time.monotonic)
    assert x.clear(ERROR_CLEAR, time.monotonic()) == p.ERR_DATA_RANGE  # not a multi-turn clear key either
    assert all(m.family.error_codes is None for m in known_models() if m.series in ("X", "P", "PRO"))
    assert np.array_equal(error_state.hardware_bits(_table(1020)), [0])


def test_virtual_y_servo_bus_watchdog_sets_its_error_code():
    clock = [100.0]
    servo = VirtualServo(4170, 1, lambda: clock[0])
    assert servo.host_write(33, bytes([1]), clock[0]) == p.ERR_NONE   # velocity mode
    assert servo.host_write(512, bytes([1]), clock[0]) == p.ERR_NONE
    assert servo.host_write(8, (5).to_bytes(2, "little"), clock[0]) == p.ERR_NONE  # 100 ms
    clock[0] += 0.2
    assert servo.read("bus_watchdog") == -1 and servo.read("error_code") == 18
    assert servo.read("torque_enable") == 1  # a hold error: torque stays on
    assert servo.host_write(528, (10).to_bytes(4, "little"), clock[0]) == p.ERR_DATA_RANGE
    assert servo.host_write(8, (0).to_bytes(2, "little"), clock[0]) == p.ERR_NONE
    assert servo.read("error_code") == 0 and servo.read("bus_watchdog") == 0


def test_the_virtual_bus_takes_y_names_with_or_without_rh():
    from dynamixel_handler.sim.cli import parse_model
    assert parse_model("YM080-230-A099") == 4170 and parse_model("ym070-210-m001-rh") == 4000


def test_virtual_y_servo_holds_on_a_following_error():
    now = time.monotonic()
    servo = VirtualServo(4170, 1, time.monotonic)
    assert servo.host_write(512, bytes([1]), now) == p.ERR_NONE
    servo.write("error_code", 17)  # Following Error: torque stays on, goals refused
    assert servo.read("torque_enable") == 1
    assert servo.host_write(532, (1000).to_bytes(4, "little", signed=True), now) == p.ERR_DATA_RANGE
    assert servo.clear(ERROR_CLEAR, now) == p.ERR_NONE
    assert servo.host_write(532, (1000).to_bytes(4, "little", signed=True), now) == p.ERR_NONE
