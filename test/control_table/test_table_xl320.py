"""The XL-320 (model 350) in the control table, the unit conversions and the virtual servo.

Expected values are written out from the e-Manual's XL-320 page (emanual.robotis.com, dxl/x/xl320):
addresses and sizes, initial values, 0..1023 over 300 deg, 0.111 rpm a speed unit with bit 10 as the
direction, Control Mode 1 wheel / 2 joint, Baud Rate 0..3, Shutdown bits overload 0, overheating 1,
input voltage 2.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from dynamixel_handler import units
from dynamixel_handler.control_table import X, family_named, model_by_number
from dynamixel_handler.core.read_plan import Read, ReadPart, decode_replies, decode_replies_plain
from dynamixel_handler.protocol import ERR_DATA_LIMIT, ERR_DATA_RANGE, ERR_NONE
from dynamixel_handler.servo import error_state
from dynamixel_handler.sim.servo import VirtualServo

from support.clock import HandClock

M = model_by_number(350)
XL320 = family_named("XL320")
DEG = 300.0 / 1023.0
DEG_S = 0.111 * 6.0


@pytest.mark.parametrize("item,address,size,eeprom", [
    ("model_number", 0, 2, True), ("firmware_version", 2, 1, True), ("id", 3, 1, True), ("baud_rate", 4, 1, True),
    ("return_delay_time", 5, 1, True), ("min_position_limit", 6, 2, True),    # CW Angle Limit
    ("max_position_limit", 8, 2, True),                                         # CCW Angle Limit
    ("operating_mode", 11, 1, True),                                            # Control Mode
    ("temperature_limit", 12, 1, True), ("min_voltage_limit", 13, 1, True), ("max_voltage_limit", 14, 1, True),
    ("pwm_limit", 15, 2, True),                                                 # Max Torque
    ("status_return_level", 17, 1, True), ("shutdown", 18, 1, True),
    ("torque_enable", 24, 1, False), ("led_colour", 25, 1, False), ("position_d_gain", 27, 1, False),
    ("position_i_gain", 28, 1, False), ("position_p_gain", 29, 1, False), ("goal_position", 30, 2, False),
    ("goal_velocity", 32, 2, False),                                            # Moving Speed
    ("torque_limit", 35, 2, False), ("present_position", 37, 2, False),
    ("present_velocity", 39, 2, False),                                         # Present Speed
    ("present_load", 41, 2, False), ("present_input_voltage", 45, 1, False), ("present_temperature", 46, 1, False),
    ("registered_instruction", 47, 1, False), ("moving", 49, 1, False), ("hardware_error_status", 50, 1, False),
    ("punch", 51, 2, False)])
def test_addresses_sizes_and_eeprom_as_the_manual(item, address, size, eeprom):
    it = M.item(item)
    assert (it.address, it.size, it.eeprom) == (address, size, eeprom)


def test_what_it_does_not_have():
    for item in ("goal_current", "present_current", "current_limit", "goal_pwm", "present_pwm", "bus_watchdog",
                 "profile_velocity", "profile_acceleration", "homing_offset", "drive_mode", "velocity_limit",
                 "acceleration_limit", "moving_status", "protocol_type", "secondary_id", "led", "realtime_tick",
                 "velocity_i_gain", "velocity_p_gain", "external_port_data_1"):
        assert not M.has(item), item
    assert M.indirect == () and M.external_ports == ()
    assert math.isnan(M.current_ma_per_pulse) and math.isnan(M.acceleration_deg_ss_per_pulse)


def test_family_driven_through_the_x_topics_in_its_own_modes():
    assert M.name == "XL-320" and M.family is XL320 and M.series == "XL320"
    assert XL320.commanded_as is X and XL320.topics is X and X.topics is X and XL320.suffix == "x"
    assert XL320.modes == {"position", "velocity"} and not XL320.used_by_default
    assert dict(M.mode_values) == {"velocity": 1, "position": 2} and M.operating_modes == (1, 2)
    assert (M.mode_name(1), M.mode_name(2), M.mode_name(3)) == ("velocity", "position", None)
    # the speed of a move in joint mode is Moving Speed (no Profile Velocity)
    assert XL320.speed_item(M.has("profile_velocity")) == "goal_velocity"
    assert M.baud_rates == {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000}


def test_factory_values():
    assert {k: M.factory[k] for k in ("baud_rate", "return_delay_time", "min_position_limit", "max_position_limit",
                                      "operating_mode", "temperature_limit", "min_voltage_limit",
                                      "max_voltage_limit", "pwm_limit", "status_return_level", "shutdown",
                                      "position_d_gain", "position_i_gain", "position_p_gain", "punch")} == {
        "baud_rate": 3, "return_delay_time": 250, "min_position_limit": 0, "max_position_limit": 1023,
        "operating_mode": 2, "temperature_limit": 65, "min_voltage_limit": 60, "max_voltage_limit": 90,
        "pwm_limit": 1023, "status_return_level": 2, "shutdown": 3, "position_d_gain": 0, "position_i_gain": 0,
        "position_p_gain": 32, "punch": 32}
    for name, value in M.factory.items():
        assert M.item(name).min_raw <= value <= M.item(name).max_raw, name


def test_positions_in_degrees_around_the_middle_and_clipped_to_the_register():
    assert units.pulse_to_unit([M] * 3, "goal_position", [0, 512, 1023]).tolist() == \
        pytest.approx([-512 * DEG, 0.0, 511 * DEG])
    assert units.unit_to_pulse([M] * 4, "goal_position", [30.0, -45.0, 200.0, -200.0]).tolist() == [614, 359, 1023, 0]
    assert units.pulse_to_unit([M], "max_voltage_limit", [90]).tolist() == pytest.approx([9.0])
    assert units.pulse_to_unit([M], "pwm_limit", [512]).tolist() == pytest.approx([50.05], abs=0.01)


def test_speeds_are_sign_magnitude_with_bit_10():
    item = M.item("goal_velocity")
    assert (item.min_raw, item.max_raw, item.direction_bit) == (-1023, 1023, 10)
    assert units.unit_to_pulse([M] * 4, "goal_velocity", [60.0, -60.0, 5000.0, -5000.0]).tolist() == \
        [90, -90, 1023, -1023]
    assert units.encode(item, [90, -90, 0]) == bytes([90, 0, 90, 4, 0, 0])  # -90: 1024 + 90 = 0x045A
    present = M.item("present_velocity")
    assert units.decode(present, bytes([90, 4, 25, 0, 0, 4]), 3).tolist() == [-90, 25, 0]  # 1024 is 0 too
    assert units.pulse_to_unit([M], "present_velocity", [-90]).tolist() == pytest.approx([-90 * DEG_S])
    assert item.to_bytes(-1023) == bytes([0xFF, 0x07]) and item.from_bytes(bytes([0xFF, 0x07])) == -1023
    with pytest.raises(OverflowError):
        item.to_bytes(1024)
    with pytest.raises(ValueError):
        units.encode(item, [-1024])
    assert units.decode(M.item("present_load"), bytes([0x00, 0x06])).tolist() == [-512]  # CW load 51.2 %


def test_sync_read_replies_decode_sign_magnitude_parts():
    # Present Position (37, 2) and Present Speed (39, 2) of two servos, one turning each way
    read = Read(37, 4, (1, 2), (ReadPart("present_position", 0, 2, False), ReadPart("present_velocity", 2, 2, False, 10)))
    joined = bytes([0x00, 0x02, 0x1E, 0x04]) + bytes([0xFF, 0x03, 0x1E, 0x00])
    for decode in (decode_replies, decode_replies_plain):
        position, velocity = decode(read, joined)
        assert position.tolist() == [512, 1023] and velocity.tolist() == [-30, 30]


def test_error_bits_in_its_own_order():
    overload, overheating, input_voltage = 0b001, 0b010, 0b100  # XL-320 Shutdown / Hardware Error Status
    assert units.decode_hardware_error([error_state.common_bits(M, overload)])["overload"].tolist() == [True]
    assert units.decode_hardware_error([error_state.common_bits(M, input_voltage)])["input_voltage"].tolist() == [True]
    assert units.decode_hardware_error([error_state.common_bits(M, overheating)])["overheating"].tolist() == [True]
    for bits in range(8):
        assert error_state.own_bits(M, error_state.common_bits(M, bits)) == bits
    x = model_by_number(1020)
    assert error_state.common_bits(x, 0x24) == 0x24 and error_state.own_bits(x, 0x24) == 0x24
    assert error_state.common_array([x, M], np.array([0x20, 0b001])).tolist() == [0x20, 0x20]  # both overload



def test_virtual_xl320_unboxed_its_write_rules_and_wheel_mode():
    clock = HandClock(100.0)
    servo = VirtualServo(350, 1, clock)
    assert servo.baudrate == 1_000_000 and not servo.supports_fast_read
    assert (servo.read("operating_mode"), servo.read("shutdown"), servo.read("pwm_limit")) == (2, 3, 1023)
    assert servo.host_write(11, bytes([3]), clock.t) == ERR_DATA_RANGE          # no Control Mode 3
    assert servo.host_write(30, (1024).to_bytes(2, "little"), clock.t) == ERR_DATA_RANGE  # beyond 0..1023
    assert servo.host_write(8, (800).to_bytes(2, "little"), clock.t) == ERR_NONE  # CCW Angle Limit 800
    assert servo.host_write(30, (900).to_bytes(2, "little"), clock.t) == ERR_DATA_LIMIT  # joint: beyond it
    assert servo.host_write(25, bytes([8]), clock.t) == ERR_DATA_RANGE          # LED colours 0..7
    # wheel mode, 300 units clockwise: 300 x 0.111 rpm = 199.8 deg/s the other way
    assert servo.host_write(11, bytes([1]), clock.t) == ERR_NONE
    assert servo.host_write(24, bytes([1]), clock.t) == ERR_NONE
    assert servo.host_write(32, (1024 + 300).to_bytes(2, "little"), clock.t) == ERR_NONE
    assert servo.read("goal_velocity") == -300
    clock.t += 1.0
    assert servo.read("present_velocity") == -300
    assert int.from_bytes(servo.read_raw(39, 2), "little") == 1024 + 300


def test_virtual_xl320_takes_torque_limit_from_max_torque_at_power_on():
    clock = HandClock(100.0)
    servo = VirtualServo(350, 1, clock)
    assert servo.host_write(15, (600).to_bytes(2, "little"), clock.t) == ERR_NONE  # Max Torque (EEPROM)
    assert servo.read("torque_limit") == 1023  # RAM: still the value taken at power on
    servo.reboot(clock.t)
    assert (servo.read("pwm_limit"), servo.read("torque_limit")) == (600, 600)
