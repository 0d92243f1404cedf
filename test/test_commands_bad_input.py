"""Bad input, one kind per test: each gets a warning that names the ID and field, changes nothing
it should not (the valid parts of the same message still apply; refused values never reach the
servo), and the node lives on: it keeps publishing and exits 0 on SIGINT.

Expected pulses use the e-Manual's scales written here (X: 4096 pulses a turn centred on 2048,
2.69 mA, 0.229 rpm; P PH54-200-S500-R: +-501,923 pulses = +-180 deg, 1 mA).
"""
from __future__ import annotations

import itertools
import math

import pytest

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsX,
    DynamixelControlPCurrent,
    DynamixelControlPExtendedPosition,
    DynamixelControlProPosition,
    DynamixelControlXCurrent,
    DynamixelControlXExtendedPosition,
    DynamixelControlXPosition,
    DynamixelControlXVelocity,
    DynamixelExtra,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import PRO, X540, P, Rig, X

X_DEG, X_ZERO = 360.0 / 4096, 2048
X_DEG_S = 0.229 * 6.0
X_MA = 2.69
X_TURN = 4096
X_EXTENDED_MAX = 1_048_575  # e-Manual: goal position in extended position mode, +-256 turns
P_DEG = 180.0 / 501923
P_TURN = 2 * 501923

POSITION, EX_POSITION, VELOCITY, CURRENT = 3, 4, 1, 0
_unique = itertools.count(1)


def x_pos(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: P, 4: PRO}, "mode_change_interval_sec:=0.0", "clear_error_interval_sec:=0.0",
            "pub_ratio/status:=3", "pub_ratio/goal:=3")
    yield r
    assert r.close() == 0


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def wait_reg(rig: Rig, dxl_id: int, item: str, value: int, timeout: float = 10.0) -> None:
    rig.wait(lambda: reg(rig, dxl_id, item) == value, timeout=timeout,
             what=f"ID {dxl_id} {item} == {value} (holds {reg(rig, dxl_id, item)})")


def position_mode(rig: Rig, *ids: int) -> None:
    """Put X servos in position mode at a known goal (0 deg) for a test to start from."""
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=list(ids), position_deg=[0.0] * len(ids)))
    for dxl_id in ids:
        wait_reg(rig, dxl_id, "operating_mode", POSITION)
        wait_reg(rig, dxl_id, "goal_position", x_pos(0.0))


def sentinel(rig: Rig) -> None:
    """A valid command on x/position_control that the test waits for: commands published earlier on
    the same topic have been handled once it lands."""
    deg = next(_unique) % 50 * 0.5
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[2], position_deg=[deg]))
    wait_reg(rig, 2, "goal_position", x_pos(deg))


# ============================================================================ kinds of bad input
def test_wrong_array_length_skips_that_array_only(rig):
    position_mode(rig, 1, 2)
    before = {i: (reg(rig, i, "profile_velocity"), reg(rig, i, "profile_acceleration")) for i in (1, 2)}
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2], position_deg=[10.0, 20.0], profile_vel_deg_s=[100.0],
                                          profile_acc_deg_ss=[1.0, 2.0, 3.0]))
    wait_reg(rig, 1, "goal_position", x_pos(10.0))
    wait_reg(rig, 2, "goal_position", x_pos(20.0))
    rig.wait_log("position_control", "'profile_vel_deg_s' has 1 values for 2 IDs", since=mark)
    rig.wait_log("position_control", "'profile_acc_deg_ss' has 3 values for 2 IDs", since=mark)
    assert {i: (reg(rig, i, "profile_velocity"), reg(rig, i, "profile_acceleration")) for i in (1, 2)} == before

    # a group topic: the only array is of the wrong length, so nothing is written
    mark = rig.mark()
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[1], position_deg=[40.0, 50.0], current_ma=[]))
    rig.wait_log("command/goal", "'position_deg' has 2 values for 1 IDs", since=mark)
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[1], velocity_deg_s=[13.74]))  # same topic: after it
    wait_reg(rig, 1, "goal_velocity", 10)
    assert reg(rig, 1, "goal_position") == x_pos(10.0)


def test_unknown_id_is_named_and_the_others_apply(rig):
    position_mode(rig, 1)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[9, 1], position_deg=[40.0, 30.0]))
    wait_reg(rig, 1, "goal_position", x_pos(30.0))
    rig.wait_log("ID 9", "not handled", since=mark)
    mark = rig.mark()
    rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=[77], temperature_limit_degc=[60.0]))
    rig.wait_log("ID 77", "not handled", since=mark)
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[88, 1]))
    wait_reg(rig, 1, "torque_enable", 0)
    rig.wait_log("ID 88", "not handled", since=mark)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[1]))
    wait_reg(rig, 1, "torque_enable", 1)


def test_wrong_series_is_refused_by_name(rig):
    position_mode(rig, 1)
    p_before = {item: reg(rig, 3, item) for item in ("operating_mode", "goal_position")}
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1, 3], position_deg=[15.0, 90.0]))
    wait_reg(rig, 1, "goal_position", x_pos(15.0))
    rig.wait_log("ID 3", "series P", "not X", since=mark)
    rig.publish("/dynamixel/command/pro/position_control", DynamixelControlProPosition(id_list=[2], position_deg=[70.0]))
    rig.wait_log("ID 2", "series X", "not PRO", since=mark)
    sentinel(rig)
    assert {item: reg(rig, 3, item) for item in p_before} == p_before
    assert reg(rig, 2, "operating_mode") == POSITION

    # a mode the series does not have: refused by name, nothing written
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[4, 3], mode=["pwm", "cur_position"]))
    rig.wait_log("ID 4", "no 'pwm' mode", since=mark)
    rig.wait_log("ID 3", "no 'cur_position' mode", since=mark)
    assert reg(rig, 4, "operating_mode") == POSITION
    assert reg(rig, 3, "operating_mode") == p_before["operating_mode"]


def test_unknown_mode_string_is_refused_and_the_rest_applies(rig):
    position_mode(rig, 1, 2)
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 2], mode=["spin_fast", "velocity"]))
    wait_reg(rig, 2, "operating_mode", VELOCITY)
    rig.wait_log("ID 1", "unknown mode 'spin_fast'", since=mark)
    assert reg(rig, 1, "operating_mode") == POSITION
    rig.wait(lambda: rig.debug_of(2)["mode"] == "velocity" and rig.debug_of(1)["mode"] == "position",
             what="modes published")


def test_nan_is_refused_and_the_rest_applies(rig):
    position_mode(rig, 1, 2)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2], position_deg=[math.nan, 25.0]))
    wait_reg(rig, 2, "goal_position", x_pos(25.0))
    rig.wait_log("ID 1", "'position_deg'", "nan", since=mark)
    assert reg(rig, 1, "goal_position") == x_pos(0.0)

    temperature = reg(rig, 2, "temperature_limit")
    mark = rig.mark()
    rig.publish("/dynamixel/command/limit",
                DynamixelLimit(id_list=[2, 1], temperature_limit_degc=[math.nan, 71.0]))
    wait_reg(rig, 1, "temperature_limit", 71)
    rig.wait_log("ID 2", "'temperature_limit_degc'", "nan", since=mark)
    assert reg(rig, 2, "temperature_limit") == temperature

    mark = rig.mark()
    msg = DynamixelExtra(id_list=[1, 2], homing_offset_deg=[math.nan, 0.0], moving_threshold_deg_s=[27.48, math.nan])
    msg.led.red_percent = [math.nan, 100.0]
    rig.publish("/dynamixel/command/extra", msg)
    wait_reg(rig, 2, "led", 1)
    wait_reg(rig, 1, "moving_threshold", 20)
    for dxl_id, field in ((1, "homing_offset_deg"), (2, "moving_threshold_deg_s"), (1, "led.red_percent")):
        rig.wait_log(f"ID {dxl_id}", f"'{field}'", "nan", since=mark)
    assert reg(rig, 1, "homing_offset") == 0 and reg(rig, 1, "led") == 0


def test_inf_is_refused_and_the_rest_applies(rig):
    position_mode(rig, 1, 2)
    speeds = {i: reg(rig, i, "profile_velocity") for i in (1, 2)}
    mark = rig.mark()
    rig.publish("/dynamixel/command/goal",
                DynamixelGoal(id_list=[1, 2], profile_vel_deg_s=[math.inf, 137.4], position_deg=[5.0, -math.inf]))
    wait_reg(rig, 2, "profile_velocity", 100)
    wait_reg(rig, 1, "goal_position", x_pos(5.0))
    rig.wait_log("ID 1", "'profile_vel_deg_s'", "inf", since=mark)
    rig.wait_log("ID 2", "'position_deg'", "-inf", since=mark)
    assert reg(rig, 1, "profile_velocity") == speeds[1]
    assert reg(rig, 2, "goal_position") == x_pos(0.0)

    # a refused rotation refuses that ID's position too: without its turns it would go elsewhere
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[1, 2], position_deg=[10.0, 20.0], rotation=[1.0, 2.0]))
    wait_reg(rig, 1, "goal_position", x_pos(370.0))
    wait_reg(rig, 2, "goal_position", x_pos(740.0))
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[1, 2], position_deg=[30.0, 40.0], rotation=[math.inf, 0.0]))
    wait_reg(rig, 2, "goal_position", x_pos(40.0))
    rig.wait_log("ID 1", "'rotation'", "inf", since=mark)
    assert reg(rig, 1, "goal_position") == x_pos(370.0)


def test_rotation_beyond_256_turns_is_clamped_to_what_the_servo_takes(rig):
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[1, 2], position_deg=[0.0, 0.0], rotation=[300.0, -1000.0]))
    wait_reg(rig, 1, "operating_mode", EX_POSITION)
    rig.wait_log("ID 1", "'rotation'", "300", "clamped", since=mark)
    rig.wait_log("ID 2", "'rotation'", "-1000", "clamped", since=mark)
    # 256 turns from 0 deg, within the servo's own range in extended position mode (+-1,048,575
    # pulses): not wrapped, not refused by the servo
    wait_reg(rig, 1, "goal_position", X_EXTENDED_MAX)
    wait_reg(rig, 2, "goal_position", x_pos(-256 * 360.0))

    mark = rig.mark()
    rig.publish("/dynamixel/command/p/extended_position_control",
                DynamixelControlPExtendedPosition(id_list=[3], position_deg=[0.0], rotation=[-400.0]))
    wait_reg(rig, 3, "goal_position", -256 * P_TURN)
    rig.wait_log("ID 3", "'rotation'", "-400", "clamped", since=mark)
    # back near home for the tests that follow
    position_mode(rig, 1, 2)
    rig.publish("/dynamixel/command/p/extended_position_control",
                DynamixelControlPExtendedPosition(id_list=[3], position_deg=[0.0]))
    wait_reg(rig, 3, "goal_position", 0)


def test_goal_beyond_the_position_limits_is_clamped_in_position_mode(rig):
    position_mode(rig, 1, 2)
    limits = {i: (reg(rig, i, "min_position_limit"), reg(rig, i, "max_position_limit")) for i in (1, 2)}
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2], position_deg=[200.0, -190.0]))
    wait_reg(rig, 1, "goal_position", limits[1][1])
    wait_reg(rig, 2, "goal_position", limits[2][0])
    rig.wait_log("ID 1", "'position_deg'", "200", "clamped to 179.9", since=mark)
    rig.wait_log("ID 2", "'position_deg'", "-190", "clamped to -180", since=mark)
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 179.912) < 0.2, timeout=15, what="ID 1 at its limit")


def test_goal_current_beyond_the_current_limit_is_clamped(rig):
    limit_x = reg(rig, 1, "current_limit")
    limit_p = reg(rig, 3, "current_limit")
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[1], current_ma=[10000.0]))
    rig.publish("/dynamixel/command/p/current_control", DynamixelControlPCurrent(id_list=[3], current_ma=[-50000.0]))
    wait_reg(rig, 1, "goal_current", limit_x)
    wait_reg(rig, 3, "goal_current", -limit_p)
    rig.wait_log("ID 1", "'current_ma'", "10000", "clamped", since=mark)
    rig.wait_log("ID 3", "'current_ma'", "-50000", "clamped", since=mark)
    rig.wait(lambda: abs(rig.debug_of(1)["current"] - limit_x * X_MA) < X_MA, what="ID 1 current at the limit")
    # a goal velocity beyond the velocity limit, likewise
    vlimit = reg(rig, 2, "velocity_limit")
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[-5000.0]))
    wait_reg(rig, 2, "goal_velocity", -vlimit)
    rig.wait_log("ID 2", "'velocity_deg_s'", "clamped", since=mark)
    rig.wait(lambda: abs(rig.debug_of(2)["velocity"] + vlimit * X_DEG_S) < X_DEG_S, what="ID 2 at the velocity limit")
    position_mode(rig, 1, 2)


def test_empty_id_list_does_nothing(rig):
    position_mode(rig, 1, 2)
    watched = ("operating_mode", "goal_position", "torque_enable", "profile_velocity", "temperature_limit",
               "return_delay_time")
    before = {i: {item: reg(rig, i, item) for item in watched} for i in (1, 3)}
    n_log = len(rig.sim.log)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[], position_deg=[50.0]))
    rig.publish("/dynamixel/command/x/extended_position_control", DynamixelControlXExtendedPosition(rotation=[3.0]))
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[], torque=[False], mode=["velocity"]))
    rig.publish("/dynamixel/command/limit", DynamixelLimit(temperature_limit_degc=[50.0]))
    rig.publish("/dynamixel/command/extra", DynamixelExtra(reboot=[True]))
    rig.publish("/dynamixel/commands/x", DxlCommandsX())
    rig.publish("/dynamixel/commands/all", DxlCommandsAll())
    for topic, msg in (("/dynamixel/command/status", DynamixelStatus(id_list=[4], torque=[True])),
                       ("/dynamixel/command/limit", DynamixelLimit(id_list=[4], temperature_limit_degc=[79.0])),
                       ("/dynamixel/command/extra", DynamixelExtra(id_list=[4], return_delay_time_us=[0.0]))):
        rig.publish(topic, msg)  # valid commands after them on the same topics
    wait_reg(rig, 4, "temperature_limit", 79)
    sentinel(rig)
    rig.fresh_states()
    assert {i: {item: reg(rig, i, item) for item in watched} for i in (1, 3)} == before
    assert rig.warnings_since(mark) == [], rig.warnings_since(mark)
    assert not any(e.instruction == 0x08 for e in rig.sim.log[n_log:])  # no reboot


def test_unknown_shortcut_command_is_named(rig):
    torque = {i: reg(rig, i, "torque_enable") for i in (1, 2, 3, 4)}
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_of", id_list=[1]))
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="", id_list=[]))
    rig.wait_log("shortcut", "unknown command 'torque_of'", since=mark)
    rig.wait_log("shortcut", "unknown command ''", since=mark)
    rig.fresh_states()
    assert {i: reg(rig, i, "torque_enable") for i in (1, 2, 3, 4)} == torque


def test_duplicate_ids_the_last_value_wins(rig):
    position_mode(rig, 1, 2)
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2, 1], position_deg=[10.0, 20.0, -30.0],
                                          profile_vel_deg_s=[100.0, 200.0, 250.0]))
    wait_reg(rig, 2, "goal_position", x_pos(20.0))
    wait_reg(rig, 1, "goal_position", x_pos(-30.0))
    wait_reg(rig, 1, "profile_velocity", round(250.0 / X_DEG_S))
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[2, 2, 1], position_deg=[5.0, -5.0, 1.0]))
    wait_reg(rig, 1, "goal_position", x_pos(1.0))
    wait_reg(rig, 2, "goal_position", x_pos(-5.0))
    rig.wait(lambda: abs(rig.debug_of(2)["position"] + 5.0) < 0.2, timeout=15, what="ID 2 at the last value")


def test_the_node_is_still_alive_after_all_the_bad_input(rig):
    assert rig.node_proc.proc.poll() is None
    n = len(rig.debug)
    rig.wait(lambda: len(rig.debug) > n + 10, what="/dynamixel/debug still published")
    out = rig.node_proc.output
    assert "Traceback" not in out
    assert "command dropped" not in out  # no callback raised
    assert " failed: " not in out  # no queued operation raised in the loop
    assert "[ERROR]" not in out and "[FATAL]" not in out
