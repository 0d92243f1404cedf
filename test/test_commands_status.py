"""Status and shortcut commands against the virtual bus: clearing a hardware error keeps the turn
count (CLEAR_KEEP_ROT, CE) or not (CLEAR), torque on after a hand move does not jump, the rate
limits of mode changes and error clears, and every shortcut command and alias.

X scales from the e-Manual: 4096 pulses a turn, 0 deg at 2048, 0.229 rpm per LSB.
"""
from __future__ import annotations

import time

import pytest

from dynamixel_handler_msgs.msg import (
    DynamixelControlPPosition,
    DynamixelControlXExtendedPosition,
    DynamixelControlXVelocity,
    DynamixelExtra,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import X540, P, Rig, X

X_DEG, X_ZERO, X_TURN = 360.0 / 4096, 2048, 4096
X_DEG_S = 0.229 * 6.0
P_DEG = 180.0 / 501923
OVERLOAD = 0x20  # hardware error status bit 5, in every servo's default shutdown mask
REBOOT = 0x08    # Protocol 2.0 instruction
GOAL_POSITION_X, TORQUE_ENABLE_X, GOAL_VELOCITY_X = 116, 64, 104  # e-Manual addresses (X)
ALL = (1, 2, 3, 4, 5)
CLEAR_INTERVAL_S = 1.5  # the rig's clear_error_interval_sec


def x_pos(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: X, 4: P, 5: X}, "mode_change_interval_sec:=2.0", f"clear_error_interval_sec:={CLEAR_INTERVAL_S}",
            "pub_ratio/status:=3", "pub_ratio/error:=3", "pub_ratio/extra.static_items:=5")
    yield r
    assert r.close() == 0


@pytest.fixture(scope="module")
def at_1000_deg(rig):
    """IDs 1-3 in extended position mode, resting at 1000 deg (2.78 turns)."""
    ids = [1, 2, 3]
    rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=ids, velocity_limit_deg_s=[1000.0] * 3))
    for i in ids:
        wait_reg(rig, i, "velocity_limit", round(1000.0 / X_DEG_S))
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=ids, position_deg=[1000.0] * 3, profile_vel_deg_s=[1000.0] * 3))
    for i in ids:
        wait_reg(rig, i, "goal_position", x_pos(1000.0))
        rig.wait(lambda i=i: abs(rig.debug_of(i)["position"] - 1000.0) < 0.1, timeout=20, what=f"ID {i} at 1000 deg")
    for i in ids:  # and settled there: the shaft follows its position loop, which passes the goal once
        rig.wait(lambda i=i: _settled(rig, i, x_pos(1000.0)), timeout=20, what=f"ID {i} at rest at 1000 deg")
    return ids


def _settled(rig: Rig, dxl_id: int, position: int) -> bool:
    """At ``position`` with no speed, over three reads 50 ms apart."""
    for k in range(3):
        if reg(rig, dxl_id, "present_position") != position or reg(rig, dxl_id, "present_velocity") != 0:
            return False
        if k < 2:
            time.sleep(0.05)
    return True


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def wait_reg(rig: Rig, dxl_id: int, item: str, value: int, timeout: float = 10.0) -> None:
    rig.wait(lambda: reg(rig, dxl_id, item) == value, timeout=timeout,
             what=f"ID {dxl_id} {item} == {value} (holds {reg(rig, dxl_id, item)})")


def overload(rig: Rig, dxl_id: int) -> None:
    """Raise an overload error; the servo drops torque, and the handler must see both."""
    rig.sim.set_hardware_error(dxl_id, OVERLOAD)
    assert reg(rig, dxl_id, "torque_enable") == 0
    rig.wait(lambda: rig.debug_of(dxl_id)["error"] and not rig.debug_of(dxl_id)["torque"],
             what=f"ID {dxl_id} error published with torque off")


def at_rest(rig: Rig, dxl_id: int, seconds: float = 0.4) -> int:
    """The present position over ``seconds``: it must not change; returns it."""
    first = reg(rig, dxl_id, "present_position")
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        assert reg(rig, dxl_id, "present_position") == first, f"ID {dxl_id} moved"
        assert reg(rig, dxl_id, "present_velocity") == 0
        time.sleep(0.05)
    return first


def reboot_when_allowed(rig: Rig, dxl_id: int) -> None:
    """The reboot shortcut; if a reboot or error clear of the servo (an earlier test's) was less than
    clear_error_interval_sec ago, the node refuses it with a line: sent again once that time has passed."""
    for _ in range(2):
        n, mark = len(rig.sim.log), rig.mark()
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="reboot", id_list=[dxl_id]))

        def sent() -> bool:
            return any(e.instruction == REBOOT and e.ids == (dxl_id,) for e in rig.sim.log[n:])
        rig.wait(lambda: sent() or f"ID {dxl_id}: reboot refused" in rig.log_since(mark), what="reboot sent or refused")
        if sent():
            return
        time.sleep(CLEAR_INTERVAL_S)
    raise AssertionError(f"ID {dxl_id}: reboot refused twice, {CLEAR_INTERVAL_S} s apart:\n{rig.log_since(mark)}")


def wait_cleared(rig: Rig, dxl_id: int) -> None:
    wait_reg(rig, dxl_id, "hardware_error_status", 0)
    wait_reg(rig, dxl_id, "torque_enable", 1)
    rig.wait(lambda: not rig.debug_of(dxl_id)["error"] and rig.debug_of(dxl_id)["torque"],
             what=f"ID {dxl_id} error gone and torque on, published")


# ============================================================================ clear error
def test_clear_keep_rot_through_status_keeps_the_turn_count(rig, at_1000_deg):
    overload(rig, 1)
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], error=[DynamixelStatus.CLEAR_KEEP_ROT]))
    wait_cleared(rig, 1)
    assert reg(rig, 1, "homing_offset") % X_TURN == 0  # whole turns put back through the homing offset
    present = at_rest(rig, 1)
    assert present == x_pos(1000.0)
    assert reg(rig, 1, "goal_position") == present
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 1000.0) < 0.1, what="1000 deg published")


def test_ce_shortcut_keeps_the_turn_count(rig, at_1000_deg):
    overload(rig, 2)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[2]))
    wait_cleared(rig, 2)
    present = at_rest(rig, 2)
    assert present == x_pos(1000.0)
    assert reg(rig, 2, "goal_position") == present
    rig.wait(lambda: abs(rig.debug_of(2)["position"] - 1000.0) < 0.1, what="1000 deg published")


def test_clear_without_keep_rot_is_within_one_turn(rig, at_1000_deg):
    overload(rig, 3)
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[3], error=[DynamixelStatus.CLEAR]))
    wait_cleared(rig, 3)
    present = at_rest(rig, 3)
    assert reg(rig, 3, "homing_offset") == 0
    assert 0 <= present < X_TURN  # one turn: the multi-turn count is gone...
    assert present == x_pos(1000.0 - 3 * 360.0)  # ...the angle within the turn is kept (1000 = 3 turns - 80)
    assert reg(rig, 3, "goal_position") == present
    rig.wait(lambda: abs(rig.debug_of(3)["position"] + 80.0) < 0.1, what="-80 deg published")


# ============================================================================ safe torque on
def test_torque_on_after_a_hand_move_does_not_jump(rig):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[5], mode=["position"]))  # whatever ran before
    wait_reg(rig, 5, "operating_mode", 3, timeout=15)  # (within mode_change_interval_sec of another change)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[5]))
    wait_reg(rig, 5, "torque_enable", 0)
    rig.turn_by_hand(5, 1000)
    moved = reg(rig, 5, "present_position")
    assert moved != reg(rig, 5, "goal_position")
    rig.wait(lambda: abs(rig.debug_of(5)["position"] - (moved - X_ZERO) * X_DEG) < 0.1, what="hand move published")
    n = len(rig.sim.log)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[5]))
    wait_reg(rig, 5, "torque_enable", 1)
    # the goal was set to where the shaft is before torque came on
    writes = [e for e in rig.sim.log[n:] if 5 in e.ids and e.address in (GOAL_POSITION_X, TORQUE_ENABLE_X)
              and e.instruction in (0x03, 0x83)]
    enable = next(k for k, e in enumerate(writes) if e.address == TORQUE_ENABLE_X)
    assert any(e.address == GOAL_POSITION_X for e in writes[:enable]), writes
    assert reg(rig, 5, "goal_position") == moved
    assert at_rest(rig, 5) == moved

    # in velocity mode the goal velocity is made neutral before torque comes back
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[5], velocity_deg_s=[60.0]))
    rig.wait(lambda: abs(rig.debug_of(5)["velocity"] - 60.0) < 2, timeout=15, what="ID 5 turning")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[5]))
    wait_reg(rig, 5, "torque_enable", 0)
    assert reg(rig, 5, "goal_velocity") != 0
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[5]))
    wait_reg(rig, 5, "torque_enable", 1)
    assert reg(rig, 5, "goal_velocity") == 0
    at_rest(rig, 5)


def test_torque_on_for_a_servo_already_on_changes_nothing(rig):
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[5]))  # whatever ran before
    wait_reg(rig, 5, "torque_enable", 1)
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[5], velocity_deg_s=[60.0]))
    rig.wait(lambda: abs(rig.debug_of(5)["velocity"] - 60.0) < 2, timeout=15, what="ID 5 turning")
    goal = reg(rig, 5, "goal_velocity")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[5]))
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[5], torque=[True]))
    rig.wait(lambda: rig.debug_of(5)["torque"], what="torque on published")
    rig.fresh_states(10)
    assert reg(rig, 5, "goal_velocity") == goal  # still turning as commanded, not stopped
    assert abs(rig.debug_of(5)["velocity"] - 60.0) < 2
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[5], velocity_deg_s=[0.0]))
    wait_reg(rig, 5, "goal_velocity", 0)


# ============================================================================ shortcut
def in_debug(rig: Rig) -> list[int]:
    return list(rig.debug[-1].status.id_list)


def test_every_shortcut_command_and_alias(rig):
    # torque_off / torque_on, disable / enable (TOFF / TON are in the test above)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_off", id_list=[4]))
    wait_reg(rig, 4, "torque_enable", 0)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_on", id_list=[4]))
    wait_reg(rig, 4, "torque_enable", 1)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="disable", id_list=[4]))
    wait_reg(rig, 4, "torque_enable", 0)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="enable", id_list=[4]))
    wait_reg(rig, 4, "torque_enable", 1)

    # reboot: RAM (LED, torque) back to the defaults
    extra = DynamixelExtra(id_list=[4])
    extra.led.red_percent = [100.0]
    rig.publish("/dynamixel/command/extra", extra)
    wait_reg(rig, 4, "led_red", 255)
    reboot_when_allowed(rig, 4)
    wait_reg(rig, 4, "led_red", 0)
    assert reg(rig, 4, "torque_enable") == 0
    rig.wait(lambda: not rig.debug_of(4)["torque"], what="torque off after the reboot, published")

    # reset_offset: homing offset back to 0
    rig.publish("/dynamixel/command/extra", DynamixelExtra(id_list=[5], homing_offset_deg=[90.0]))
    wait_reg(rig, 5, "homing_offset", 1024)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="reset_offset", id_list=[5]))
    wait_reg(rig, 5, "homing_offset", 0)

    # clear_error (the long name of CE)
    overload(rig, 5)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="clear_error", id_list=[5]))
    wait_cleared(rig, 5)

    # remove_id / RMID, add_id / ADID
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="RMID", id_list=[5]))
    rig.wait(lambda: in_debug(rig) == [1, 2, 3, 4], what="ID 5 removed")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="remove_id", id_list=[4]))
    rig.wait(lambda: in_debug(rig) == [1, 2, 3], what="ID 4 removed")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="ADID", id_list=[5]))
    rig.wait(lambda: in_debug(rig) == [1, 2, 3, 5], what="ID 5 added")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="add_id", id_list=[4]))
    rig.wait(lambda: in_debug(rig) == [1, 2, 3, 4, 5], what="ID 4 added")
    rig.wait(lambda: rig.debug_of(4)["mode"] == "position" and rig.debug_of(5)["ping"], what="added IDs read")


def test_empty_id_list_and_254_mean_every_handled_id(rig):
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[]))
    for i in ALL:
        wait_reg(rig, i, "torque_enable", 0)
    resting = {i: reg(rig, i, "present_position") for i in ALL}  # torque off: the shafts stand still
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_on", id_list=[254]))
    for i in ALL:
        wait_reg(rig, i, "torque_enable", 1)
    rig.wait(lambda: all(rig.debug_of(i)["torque"] for i in ALL), what="torque on for all, published")
    # safe torque on for every one of them: each holds where it stood (goal := present), none moves
    for i in ALL:
        if reg(rig, i, "operating_mode") in (3, 4, 5):  # position modes (a velocity goal is 0)
            assert reg(rig, i, "goal_position") == resting[i], f"ID {i}"
        assert at_rest(rig, i) == resting[i], f"ID {i}"


# ============================================================================ rate limits
def test_mode_change_is_rate_limited(rig):
    """A change asked for too soon waits until mode_change_interval_sec has passed, then goes
    through with the goal that came with it."""
    n = len(rig.sim.log)
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[4], mode=["velocity"]))
    wait_reg(rig, 4, "operating_mode", 1, timeout=15)  # (an earlier test's change may make it wait too)
    mark = rig.mark()
    rig.publish("/dynamixel/command/p/position_control", DynamixelControlPPosition(id_list=[4], position_deg=[30.0]))
    rig.wait_log("ID 4", "mode_change_interval_sec=2s ago: applied in", since=mark)
    wait_reg(rig, 4, "operating_mode", 3, timeout=5)
    # on the wire: the position mode written the interval after the velocity mode, not at once
    mode_address = rig.sim.servo(4).model.item("operating_mode").address
    writes = [(e.time, e.params[-1]) for e in rig.sim.log[n:]
              if e.instruction == 0x03 and e.ids == (4,) and e.address == mode_address]
    velocity_at = max(t for t, v in writes if v == 1)
    position_at = min(t for t, v in writes if v == 3 and t > velocity_at)
    assert position_at - velocity_at >= 2.0 - 0.05, writes
    wait_reg(rig, 4, "goal_position", round(30.0 / P_DEG))
    rig.wait(lambda: abs(rig.debug_of(4)["position"] - 30.0) < 0.01, timeout=15, what="ID 4 at 30 deg")


def test_error_clear_is_rate_limited(rig):
    # an earlier test may have rebooted ID 4 less than the interval ago (a clear, a reconnect, an
    # add_id): the first clear below must be the first of a fresh interval
    time.sleep(CLEAR_INTERVAL_S)
    overload(rig, 4)
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[4]))
    rig.wait_log("ID 4: hardware error cleared", since=mark)
    wait_cleared(rig, 4)
    overload(rig, 4)  # in error again at once: the next clear waits for the interval
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[4]))
    rig.wait_log("ID 4 error clear refused", "clear_error_interval_sec=1.5", since=mark)
    assert rig.log_since(mark).count("ID 4: hardware error cleared") == 1
    time.sleep(1.5)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[4]))
    wait_cleared(rig, 4)
