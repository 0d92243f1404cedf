"""Hostile input through the real topics: a huge message, a flood of refused commands, a huge
string. Each is refused or survived with few log lines, and the loop keeps running; a control
message with only id_list switches the servo's mode, as the docs say.
"""
from __future__ import annotations

import time

import pytest

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsX,
    DynamixelControlXPosition,
    DynamixelControlXVelocity,
    DynamixelGoal,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import Rig, X

XL430 = 1060  # XL430-W250: no current sensor, so no current mode
POSITION, VELOCITY = 3, 1


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X, 3: XL430}, "mode_change_interval_sec:=0.0", "pub_ratio/status:=3")
    yield r
    assert r.close() == 0


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def lines_with(rig: Rig, mark: int, text: str) -> list[str]:
    return [line for line in rig.node_proc.lines[mark:] if text in line]


def test_control_message_with_only_id_list_switches_the_mode(rig):
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[0.0]))
    rig.wait(lambda: reg(rig, 1, "operating_mode") == POSITION, what="ID 1 in position mode")
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[1]))
    rig.wait(lambda: reg(rig, 1, "operating_mode") == VELOCITY, what="ID 1 in velocity mode")
    rig.wait_log("ID 1: operating mode -> velocity", since=mark)
    assert reg(rig, 1, "goal_velocity") == 0  # no goal given: none written (the safe torque on zeroes it)
    # and back, through the bundle's part
    rig.publish("/dynamixel/commands/x", DxlCommandsX(position_control=DynamixelControlXPosition(id_list=[1])))
    rig.wait(lambda: reg(rig, 1, "operating_mode") == POSITION, what="ID 1 back in position mode")


def test_a_huge_id_list_is_refused_whole_with_one_line(rig):
    mark = rig.mark()
    trips = len(lines_with(rig, 0, "bus watchdog"))
    # 10,000 entries of an unknown ID on /dynamixel/commands/all, 100,000 on the X bundle
    rig.publish("/dynamixel/commands/all",
                DxlCommandsAll(goal=DynamixelGoal(id_list=[99] * 10_000, position_deg=[1.0] * 10_000)))
    rig.publish("/dynamixel/commands/x", DxlCommandsX(position_control=DynamixelControlXPosition(
        id_list=[99] * 100_000, position_deg=[1.0] * 100_000)))
    rig.wait_log("commands/all.goal: id_list has 10000 IDs, more than the 253", "refused", since=mark)
    rig.wait_log("commands/x.position_control: id_list has 100000 IDs", "refused", since=mark)
    # the loop went on: a valid command right behind them is applied
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[2], position_deg=[30.0]))
    rig.wait(lambda: reg(rig, 2, "goal_position") == 2048 + round(30.0 / (360 / 4096)), what="ID 2 goal 30 deg")
    assert not lines_with(rig, mark, "is not handled")
    assert len(lines_with(rig, 0, "bus watchdog")) == trips


def test_many_bad_ids_in_one_message_give_one_line_naming_a_few(rig):
    mark = rig.mark()
    ids = list(range(100, 300 - 47)) + [2]  # 153 unknown IDs, then a handled one
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=ids, position_deg=[0.0] * (len(ids) - 1) + [45.0]))
    rig.wait(lambda: reg(rig, 2, "goal_position") == 2048 + 512, what="ID 2 goal 45 deg")
    line = rig.wait_log("IDs 100, 101, 102, 103, 104 and 148 more are not handled: ignored", since=mark)
    assert len(line) < 200
    time.sleep(0.3)
    assert len(lines_with(rig, mark, "not handled")) == 1


def test_refused_mode_changes_at_100_hz_log_once_a_second(rig):
    mark = rig.mark()
    msg = DynamixelStatus(id_list=[3], mode=["current"])  # the XL430 has no current mode
    rig.publish("/dynamixel/command/status", msg)
    start = time.monotonic()
    sent = 1
    while time.monotonic() - start < 2.5:
        rig.publish("/dynamixel/command/status", msg)
        sent += 1
        time.sleep(0.01)
    rig.wait_log("ID 3", "no current sensor", "more)", since=mark)
    refused = lines_with(rig, mark, "no current sensor")
    assert sent > 100
    assert 2 <= len(refused) <= 4, refused  # ~one a second, not one per message
    assert reg(rig, 3, "operating_mode") != 0


def test_a_huge_string_is_cut_in_the_log(rig):
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="Z" * 100_000, id_list=[1]))
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], mode=["Q" * 100_000]))
    line = rig.wait_log("shortcut: unknown command", since=mark)
    assert "(100000 characters)" in line and len(line) < 400, len(line)
    line = rig.wait_log("unknown mode", since=mark)
    assert "(100000 characters)" in line and len(line) < 400, len(line)
    assert max(len(line) for line in rig.node_proc.lines[mark:]) < 1000
