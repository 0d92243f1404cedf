"""The XL-320 (model 350) through the real node on the virtual bus, driven through the X topics.

The expected pulses are written out from the e-Manual's XL-320 page (not taken from the product's
tables): positions 0..1023 over 300 deg with 512 in the middle, speeds at 0.111 rpm a unit with
bit 10 as the direction (1024 + n: n units clockwise, negative here), Control Mode 1 wheel / 2
joint, Max Torque 1023 = 100 %, Baud Rate 3 = 1 Mbps (its factory value, so the node runs at 1 Mbps).
What the XL-320 lacks (current, bus watchdog, profiles, drive mode ...) reads back as the spec says
for missing items, and a command for a mode it lacks is refused with one line.
"""
from __future__ import annotations

import math

import pytest

from dynamixel_handler_msgs.msg import (
    DxlCommandsX,
    DynamixelControlXCurrent,
    DynamixelControlXPosition,
    DynamixelControlXVelocity,
    DynamixelExtra,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import Rig
from support.waits import wait_state

DEG = 300.0 / 1023.0       # deg per position unit
ZERO = 512                 # the middle of 0..1023
DEG_S = 0.111 * 6.0        # deg/s per speed unit
PERCENT = 100.0 / 1023.0   # Max Torque: % per unit
CW = 1 << 10               # the direction bit of speeds and load
JOINT, WHEEL = 2, 1        # Control Mode values
XL320, IDS = 350, (1, 2)
XM430, X_ID = 1020, 3      # an X servo on the same bus, set to 1 Mbps


@pytest.fixture(scope="module")
def rig():
    r = Rig({**{i: XL320 for i in IDS}, X_ID: XM430}, "baudrate:=1000000", "init/used_servo_series.XL320:=true",
            "mode_change_interval_sec:=0.0", "pub_ratio/status:=3", "pub_ratio/goal:=3", "pub_ratio/gain:=3",
            "pub_ratio/limit:=3", "pub_ratio/error:=3", "pub_ratio/extra.dynamic_items:=3",
            "pub_ratio/extra.static_items:=3", "clear_error_interval_sec:=0.0",
            sim_kwargs={"baudrate": 1_000_000})
    # the modes the start-up found, before any test's command changes them (any order)
    for dxl_id in IDS:
        r.wait(lambda i=dxl_id: r.state_of("status", "mode", i) is not None, what=f"status of ID {dxl_id}")
    r.modes_at_start = {i: r.state_of("status", "mode", i) for i in IDS}
    yield r
    assert r.close() == 0


def raw(rig: Rig, dxl_id: int, address: int, size: int = 2) -> int:
    """A register as its bytes read on the wire (unsigned, little-endian)."""
    return int.from_bytes(rig.sim.servo(dxl_id).read_raw(address, size), "little")


def wait_raw(rig: Rig, dxl_id: int, expected: dict[tuple[int, int], int]) -> None:
    """Wait until each (address, size) register of ``dxl_id`` holds its value."""
    def now() -> dict[tuple[int, int], int]:
        return {key: raw(rig, dxl_id, *key) for key in expected}
    try:
        rig.wait(lambda: now() == expected, what=f"ID {dxl_id} registers {expected}")
    except AssertionError:
        assert now() == expected


GOAL_POSITION, MOVING_SPEED, CONTROL_MODE = (30, 2), (32, 2), (11, 1)


def set_mode(rig: Rig, dxl_id: int, mode: str, value: int) -> None:
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[dxl_id], mode=[mode]))
    wait_raw(rig, dxl_id, {CONTROL_MODE: value})
    rig.wait(lambda: rig.state_of("status", "mode", dxl_id) == mode, what=f"status.mode of ID {dxl_id} = {mode}")


def test_recognised_at_start_up_with_its_name(rig):
    for dxl_id in IDS:
        assert f"ID {dxl_id}: XL-320" in rig.output, rig.output
        rig.wait(lambda i=dxl_id: rig.state_of("extra", "model_number", i) == XL320, what=f"extra of ID {dxl_id}")
        assert rig.state_of("extra", "model", dxl_id) == "XL320"
        assert rig.modes_at_start[dxl_id] == "position"  # factory Control Mode 2: joint


def test_x_position_command_in_degrees_lands_as_the_raw_goal(rig):
    set_mode(rig, 1, "position", JOINT)
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1], position_deg=[30.0], profile_vel_deg_s=[60.0]))
    # 30 deg / 0.2933 = 102.3 units above the middle; 60 deg/s / 0.666 = 90.1 units of Moving Speed
    wait_raw(rig, 1, {CONTROL_MODE: JOINT, GOAL_POSITION: ZERO + 102, MOVING_SPEED: 90})
    wait_state(rig, "goal", "position_deg", 1, 102 * DEG)
    # beyond 300 deg the register's end (CCW Angle Limit 1023) is the goal, never a wrap
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[-170.0]))
    wait_raw(rig, 1, {GOAL_POSITION: 0})
    # the bundle topic reaches it too
    bundle = DxlCommandsX()
    bundle.position_control = DynamixelControlXPosition(id_list=[1], position_deg=[-45.0])
    rig.publish("/dynamixel/commands/x", bundle)
    wait_raw(rig, 1, {GOAL_POSITION: ZERO - 153})  # 45 / 0.2933 = 153.45


def test_one_x_command_for_an_xl320_and_an_x_servo(rig):
    """The speed of the move goes to each servo's own item: Moving Speed on the XL-320, Profile
    Velocity on the XM430 (0.229 rpm a unit, 4096 pulses a turn around 2048)."""
    set_mode(rig, 1, "position", JOINT)
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, X_ID], position_deg=[20.0, 20.0], profile_vel_deg_s=[60.0, 60.0]))
    wait_raw(rig, 1, {GOAL_POSITION: ZERO + 68, MOVING_SPEED: 90})  # 20 / 0.2933 = 68.2
    wait_raw(rig, X_ID, {(116, 4): 2048 + 228, (112, 4): 44})     # 20 / 0.0879 = 227.6; 60 / 1.374 = 43.7


def test_present_position_and_velocity_come_back_in_units_with_the_direction_bit(rig):
    servo = rig.sim.servo(2)
    servo.pin("present_position", 700)
    servo.pin("present_velocity", -25)
    try:
        assert raw(rig, 2, 39) == CW | 25  # on the wire: 25 units clockwise
        wait_state(rig, "present", "position_deg", 2, (700 - ZERO) * DEG)
        wait_state(rig, "present", "velocity_deg_s", 2, -25 * DEG_S)
        servo.pin("present_velocity", 40)
        assert raw(rig, 2, 39) == 40
        wait_state(rig, "present", "velocity_deg_s", 2, 40 * DEG_S)
    finally:
        servo.pin("present_position", None)
        servo.pin("present_velocity", None)


def test_wheel_mode_turns_either_way(rig):
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[-60.0]))
    wait_raw(rig, 2, {CONTROL_MODE: WHEEL, MOVING_SPEED: CW | 90})  # 90 units clockwise
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], torque=[True]))
    rig.wait(lambda: (rig.state_of("present", "velocity_deg_s", 2) or 0.0) < -50.0, what="ID 2 turning clockwise")
    rig.wait(lambda: rig.state_of("status", "mode", 2) == "velocity", what="status.mode of ID 2")
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[30.0]))
    wait_raw(rig, 2, {MOVING_SPEED: 45})
    rig.wait(lambda: (rig.state_of("present", "velocity_deg_s", 2) or 0.0) > 25.0, what="ID 2 turning the other way")
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], torque=[False]))
    wait_raw(rig, 2, {(24, 1): 0})


def test_mode_changes_both_ways(rig):
    for mode, value in (("velocity", WHEEL), ("position", JOINT), ("velocity", WHEEL), ("position", JOINT)):
        set_mode(rig, 1, mode, value)


def test_a_current_command_is_refused_with_one_clear_line(rig):
    set_mode(rig, 1, "position", JOINT)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[1], current_ma=[100.0]))
    line = rig.wait_log("ID 1", "XL-320", "current", since=mark)
    assert "ignored" in line
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], mode=["pwm"]))
    rig.wait_log("ID 1", "XL-320", "pwm", since=mark)
    assert raw(rig, 1, *CONTROL_MODE) == JOINT
    assert len([ln for ln in rig.log_since(mark).splitlines() if "current" in ln]) == 1


def test_limit_write_lands_in_eeprom_units(rig):
    rig.publish("/dynamixel/command/limit",
                DynamixelLimit(id_list=[1], max_position_limit_deg=[100.0], min_position_limit_deg=[-100.0],
                               temperature_limit_degc=[60.0], pwm_limit_percent=[50.0]))
    # CCW / CW Angle Limit 512 +- 341 (100 / 0.2933 = 341.0), Temperature Limit 60, Max Torque 511.5 -> 512;
    # Torque Limit (35), which the servo takes from Max Torque only at power on, too: the limit holds at once
    wait_raw(rig, 1, {(8, 2): ZERO + 341, (6, 2): ZERO - 341, (12, 1): 60, (15, 2): 512, (35, 2): 512})
    wait_state(rig, "limit", "max_position_limit_deg", 1, 341 * DEG)
    wait_state(rig, "limit", "pwm_limit_percent", 1, 512 * PERCENT)
    # a goal beyond the new limit is held to it
    try:
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[140.0]))
        wait_raw(rig, 1, {GOAL_POSITION: ZERO + 341})
    finally:  # the factory's limits again, for the tests that run after this one
        servo = rig.sim.servo(1)
        for name, value in (("min_position_limit", 0), ("max_position_limit", 1023), ("pwm_limit", 1023),
                            ("torque_limit", 1023), ("temperature_limit", 65)):
            servo.write(name, value)
        rig.wait(lambda: rig.state_of("limit", "max_position_limit_deg", 1) > 149.0, what="ID 1's limits read again")


def test_what_it_lacks_reads_back_as_the_spec_says(rig):
    for group, field in (("present", "current_ma"), ("goal", "current_ma"), ("limit", "current_limit_ma"),
                         ("goal", "pwm_percent"), ("goal", "profile_acc_deg_ss"), ("limit", "velocity_limit_deg_s"),
                         ("extra", "bus_watchdog_ms"), ("extra", "homing_offset_deg")):
        wait_state(rig, group, field, 2, math.nan, 0)
    assert rig.state_of("gain", "velocity_p_gain_pulse", 2) == 0
    assert rig.state_of("gain", "position_p_gain_pulse", 2) == 32  # its factory P Gain
    assert rig.state_of("extra", "drive_mode.reverse_mode", 2) is False
    assert rig.state_of("extra", "moving_status.velocity_profile", 2) == "none"
    assert rig.state_of("extra", "drive_mode.profile_configuration", 2) == "velocity_based"
    assert rig.state_of("extra", "protocol_type", 2) == 2


def test_led_colour_bits(rig):
    msg = DynamixelExtra(id_list=[1])
    msg.led.green_percent, msg.led.blue_percent = [100.0], [100.0]
    rig.publish("/dynamixel/command/extra", msg)
    wait_raw(rig, 1, {(25, 1): 0b110})  # LED 6: cyan (green and blue)
    wait_state(rig, "extra", "led.green_percent", 1, 100.0, 0)
    assert rig.state_of("extra", "led.red_percent", 1) == 0.0
    assert rig.state_of("extra", "led.blue_percent", 1) == 100.0


def test_hardware_error_bits_in_its_own_order_and_cleared_by_a_reboot(rig):
    # Shutdown 3 (factory): bit 0 overload, bit 1 overheating; bit 2 (input voltage) not set
    rig.wait(lambda: rig.state_of("extra", "shutdown.overload_error", 2) is not None, what="extra of ID 2")
    assert (rig.state_of("extra", "shutdown.overload_error", 2), rig.state_of("extra", "shutdown.overheating_error", 2),
            rig.state_of("extra", "shutdown.input_voltage_error", 2)) == (True, True, False)
    rig.sim.servo(2).set_hardware_error(0b001)  # overload
    rig.wait(lambda: rig.state_of("error", "overload", 2) is True, what="error.overload of ID 2")
    assert rig.state_of("error", "input_voltage", 2) is False
    rig.wait(lambda: rig.state_of("status", "error", 2) is True, what="status.error of ID 2")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[2]))
    wait_raw(rig, 2, {(50, 1): 0})
    rig.wait(lambda: rig.state_of("status", "error", 2) is False, what="status.error of ID 2 cleared")
