"""DYNAMIXEL-Y servos through the real node on the virtual bus, driven through the
series-independent topics (/dynamixel/commands/all, /dynamixel/command/{status,limit}): recognised
with their names, goals in degrees land as the e-Manual's pulses, present values come back in
units, a mode change and a limit write work, an error code shows in the error state and is cleared
with the error clear instruction (no reboot), and what the Y table lacks reads as not supported.

The expected pulses are written out from the e-Manual (docs/en/dxl/y/ym080-230-a099-rh and
ym070-210-m001-rh), not taken from the product's tables: 524,288 pulses an output turn
(±262,144 = ±180°), 0.01 rev/min, 0.01 A, Present Input Voltage 0.01 V, limits 0.1 V.
"""
from __future__ import annotations

import math

import pytest

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import Rig
from support.waits import regs, wait_regs

YM080_A099, YM070_M001 = 4170, 4000
DEG = 180.0 / 262_144          # one pulse at the output
DEG_S = 0.01 * 6.0             # 0.01 rev/min in deg/s
MA = 10.0                      # 0.01 A


def pulses(value: float, per_lsb: float) -> int:
    return round(value / per_lsb)


PARAMS = ("init/used_servo_series.Y:=true", "mode_change_interval_sec:=0.0", "pub_ratio/status:=3",
          "pub_ratio/error:=3", "pub_ratio/limit:=5", "clear_error_interval_sec:=0.0")


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: YM080_A099, 2: YM070_M001}, *PARAMS)
    yield r
    assert r.close() == 0


def all_goal(**fields) -> DxlCommandsAll:
    msg = DxlCommandsAll()
    msg.goal = DynamixelGoal(**fields)
    return msg


def test_recognised_with_their_names_and_no_series_topics(rig):
    assert "ID 1: YM080-230-A099-RH" in rig.output, rig.output
    assert "ID 2: YM070-210-M001-RH" in rig.output, rig.output
    names = [name for name, _ in rig.node.get_topic_names_and_types()]
    assert "/dynamixel/commands/all" in names
    assert not any(n.startswith(("/dynamixel/commands/y", "/dynamixel/command/y/")) for n in names), names


def test_position_in_degrees_lands_as_output_pulses(rig):
    rig.publish("/dynamixel/commands/all", all_goal(id_list=[1, 2], position_deg=[45.0, -30.0],
                                                    profile_vel_deg_s=[6.0, 60.0]))
    wait_regs(rig, 1, {"goal_position": pulses(45.0, DEG), "profile_velocity": pulses(6.0, DEG_S)})
    wait_regs(rig, 2, {"goal_position": pulses(-30.0, DEG), "profile_velocity": pulses(60.0, DEG_S)})
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 45.0) < 0.5, timeout=20, what="ID 1 at 45 deg")


def test_present_values_in_units(rig):
    servo = rig.sim.servo(2)
    servo.pin("present_current", 123)          # 1.23 A
    servo.pin("present_input_voltage", 2_412)  # 24.12 V
    servo.pin("present_temperature", 41)       # the motor's
    try:
        rig.fresh_states(count=40)
        rig.wait(lambda: rig.state_of("present", "current_ma", 2) == pytest.approx(1230.0), what="current in mA")
        rig.wait(lambda: rig.state_of("present", "input_voltage_v", 2) == pytest.approx(24.12), what="voltage")
        rig.wait(lambda: rig.state_of("present", "temperature_degc", 2) == pytest.approx(41.0), what="temperature")
        velocity = servo.read("present_velocity")
        assert rig.state_of("present", "velocity_deg_s", 2) == pytest.approx(velocity * DEG_S, abs=30 * DEG_S)
    finally:
        for item in ("present_current", "present_input_voltage", "present_temperature"):
            servo.pin(item, None)


def test_mode_change_and_limit_write(rig):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], mode=["velocity"]))
    wait_regs(rig, 2, {"operating_mode": 1})
    rig.publish("/dynamixel/commands/all", all_goal(id_list=[2], velocity_deg_s=[120.0]))
    wait_regs(rig, 2, {"goal_velocity": pulses(120.0, DEG_S)})
    # velocity mode arms the 2-byte bus watchdog (20 ms a unit: default/bus_watchdog 500 ms = 25)
    rig.wait(lambda: regs(rig, 2, "bus_watchdog")["bus_watchdog"] == 25, what="bus watchdog armed")
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], mode=["ex_position"]))
    rig.wait_log("ID 2", "ex_position", since=mark)
    assert regs(rig, 2, "operating_mode") == {"operating_mode": 1}
    rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=[1], current_limit_ma=[5000.0],
                                                           max_voltage_limit_v=[30.0]))
    wait_regs(rig, 1, {"current_limit": pulses(5000.0, MA), "max_voltage_limit": 300, "torque_enable": 1})
    rig.wait(lambda: rig.state_of("limit", "current_limit_ma", 1) == pytest.approx(5000.0), what="limit read back")


def test_error_code_shows_and_is_cleared_without_reboot(rig):
    servo = rig.sim.servo(1)
    mark = rig.mark()
    rig.sim.clear_log()
    servo.write("error_code", 5)  # Overload Error: torque off
    rig.wait_log("ID 1", "Overload Error", since=mark)
    rig.wait(lambda: rig.state_of("error", "overload", 1) is True, what="overload in the error state")
    rig.wait(lambda: rig.state_of("status", "error", 1) is True, what="error flag in the status")
    assert rig.state_of("error", "input_voltage", 1) is False
    assert servo.read("torque_enable") == 0
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[1]))
    wait_regs(rig, 1, {"error_code": 0, "torque_enable": 1})
    rig.wait_log("ID 1", "cleared", since=mark)
    rig.wait(lambda: rig.state_of("status", "error", 1) is False, what="error flag gone")
    names = [e.name for e in rig.transactions() if 1 in e.ids]
    assert "clear" in names and "reboot" not in names, names


def test_an_error_the_clear_cannot_clear_is_reported(rig):
    servo = rig.sim.servo(2)
    servo.write("error_code", 13)  # Encoder Error: not clearable
    try:
        rig.wait(lambda: rig.state_of("error", "motor_encoder", 2) is True, what="encoder error")
        mark = rig.mark()
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[2]))
        rig.wait_log("ID 2", "Encoder Error", "not cleared", since=mark)
        assert servo.read("error_code") == 13
    finally:
        servo.write("error_code", 0)


def test_a_warning_code_is_logged_but_is_no_error(rig):
    servo = rig.sim.servo(1)
    mark = rig.mark()
    servo.write("error_code", 9)  # Battery Warning: torque stays on, nothing to clear
    try:
        line = rig.wait_log("ID 1", "Battery Warning", since=mark)
        assert "WARN" in line and "clear_error" not in line, line
        rig.fresh_states(count=5)
        assert rig.state_of("status", "error", 1) is False
    finally:
        servo.write("error_code", 0)


def test_unsupported_items_read_as_not_supported(rig):
    rig.fresh_states(count=5)
    rig.wait(lambda: rig.group("extra") is not None, what="extra read")
    # no Shutdown, LED colours or external ports on Y; a mode Y lacks is refused above
    assert rig.state_of("extra", "shutdown.overload_error", 1) is False
    assert rig.state_of("extra", "model", 1) == "Y"
    assert rig.state_of("extra", "model_number", 1) == YM080_A099
    assert rig.state_of("extra", "led.red_percent", 1) == 0.0  # its one LED (0/1), off
    assert math.isnan(rig.state_of("extra", "led.green_percent", 1))
    assert rig.state_of("extra", "bus_watchdog_ms", 1) >= 0.0  # 2 bytes, 20 ms a unit
    assert rig.state_of("extra", "restore_configuration.ram_restore", 1) is False
    assert math.isnan(rig.state_of("extra", "pwm_slope_percent", 1))
    assert rig.state_of("present", "pwm_percent", 1) == pytest.approx(0.0, abs=100.0)  # Y has PWM


def test_hybrid_area_is_written_at_start_up_only_where_it_differs(rig):
    """Gains and profiles are Y's Hybrid area, stored in non-volatile memory when written with
    torque off: the start-up's profile defaults (1000 deg/s, 6008 deg/s^2, each lowered to the
    servo's Velocity / Acceleration Limit: its profiles take no more) go only to a servo that holds
    other values."""
    assert rig.stop_node() == 0
    one = rig.sim.servo(1)  # YM080-230-A099: a Velocity Limit of 121 deg/s
    one.write("profile_velocity", min(pulses(1000.0, DEG_S), one.read("velocity_limit")))
    one.write("profile_acceleration", min(6008, one.read("acceleration_limit")))  # 1 deg/s^2 a unit
    rig.sim.servo(2).write("profile_velocity", 123)
    rig.sim.clear_log()
    rig.start_node(*PARAMS)
    rig.wait_new(["debug"], 3)  # the new node's loop runs (its set-up is done): not the last node's messages
    writes = [(e.ids, e.address) for e in rig.transactions() if e.name == "write" and e.address in (240, 244)]
    assert ((1,), 244) not in writes and ((1,), 240) not in writes, writes
    assert ((2,), 244) in writes, writes
    assert rig.sim.servo(2).read("profile_velocity") == pulses(1000.0, DEG_S)


ALL_Y = {4000: "YM070-210-M001-RH", 4010: "YM070-210-B001-RH", 4020: "YM070-210-R051-RH",
         4030: "YM070-210-R099-RH", 4040: "YM070-210-A051-RH", 4050: "YM070-210-A099-RH",
         4120: "YM080-230-M001-RH", 4130: "YM080-230-B001-RH", 4140: "YM080-230-R051-RH",
         4150: "YM080-230-R099-RH", 4160: "YM080-230-A051-RH", 4170: "YM080-230-A099-RH"}


def test_every_y_model_is_recognised_by_name_and_takes_a_goal_in_degrees():
    # the twelve model numbers and names of the e-Manual's Y pages, one servo each on one bus
    servos = {k + 1: number for k, number in enumerate(ALL_Y)}
    r = Rig(servos, *PARAMS, "baudrate:=1000000", sim_kwargs={"baudrate": 1_000_000, "wire_timing": False})
    try:
        for dxl_id, number in servos.items():
            assert f"ID {dxl_id}: {ALL_Y[number]} (model {number}, series Y) handled" in r.output, r.output
        ids = list(servos)
        degrees = [5.0 * k - 30.0 for k in range(len(ids))]
        r.publish("/dynamixel/commands/all", all_goal(id_list=ids, position_deg=degrees))
        for dxl_id, deg in zip(ids, degrees):
            wait_regs(r, dxl_id, {"goal_position": pulses(deg, DEG)})
    finally:
        assert r.close() == 0
