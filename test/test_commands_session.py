"""A session as the design document shows it, end to end through rclpy and the virtual bus."""
from __future__ import annotations

import pytest

from dynamixel_handler_msgs.msg import DxlCommandsX, DynamixelControlXPosition, DynamixelShortcut

from support.rig import PRO, X540, P, Rig, X


@pytest.fixture
def rig():
    r = Rig({1: X, 2: X540, 3: P, 4: PRO}, "init/torque_auto_enable:=false", "pub_ratio/status:=5")
    yield r
    assert r.close() == 0


def test_torque_on_then_position_control_reaches_the_goal(rig):
    rig.wait(lambda: not rig.debug_of(1)["torque"], what="torque off at start")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TON", id_list=[1, 2]))
    rig.wait(lambda: rig.debug_of(1)["torque"] and rig.debug_of(2)["torque"], what="torque on for 1 and 2")
    assert not rig.debug_of(3)["torque"]
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2], position_deg=[90.0, -45.0]))
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 90.0) < 0.5 and abs(rig.debug_of(2)["position"] + 45.0) < 0.5,
             timeout=15, what="present position at the goal")
    assert rig.debug_of(1)["goal_position"] == pytest.approx(90.0, abs=0.1)
    assert rig.sim.servo(1).read("goal_position") == 2048 + 1024
    assert rig.sim.servo(2).read("goal_position") == 2048 - 512


def test_extended_position_with_rotation_and_program_topic(rig):
    cmd = DxlCommandsX()
    cmd.extended_position_control.id_list = [1]
    cmd.extended_position_control.position_deg = [72.0]
    cmd.extended_position_control.rotation = [1.0]
    cmd.status.id_list = [1]
    cmd.status.torque = [True]
    rig.publish("/dynamixel/commands/x", cmd)
    rig.wait(lambda: rig.debug_of(1)["mode"] == "ex_position", what="mode ex_position")
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 432.0) < 0.5, timeout=15, what="432 deg")
    assert rig.sim.servo(1).read("goal_position") == 2048 + round(432 / 360 * 4096)
