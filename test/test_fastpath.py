"""The node beyond rclpy's public API (``dynamixel_handler/ros/fastpath.py``) and without it.

``DYNAMIXEL_HANDLER_FAST_PATH`` chooses the paths: ``none`` is the public-API fallback the node also
takes by itself when a start-up check fails. On every choice the node says which paths it uses in
one line, and a user sees the same node: commands on a topic and in a bundle reach the servos'
registers, a shortcut applies, and the states come back on /dynamixel/states and /dynamixel/debug.
"""
from __future__ import annotations

import pytest

from dynamixel_handler.ros.fastpath import FAST_ENV
from dynamixel_handler_msgs.msg import DxlCommandsX, DynamixelControlXPosition, DynamixelShortcut

from support.rig import X540, Rig, X

#: X series: 4096 pulses a turn, 0° at 2048
X_ZERO, X_DEG = 2048, 360 / 4096

CHOICES = {
    "none": "public rclpy API only; raw_intake off (DYNAMIXEL_HANDLER_FAST_PATH=none): commands go through rclpy "
            "message objects; raw_publish off (DYNAMIXEL_HANDLER_FAST_PATH=none): states go through rclpy message "
            "objects; detached_intake off (DYNAMIXEL_HANDLER_FAST_PATH=none): command subscriptions run in the executor",
    "all": "fast paths: raw_intake, raw_publish, detached_intake (rclpy ",
    "raw_publish": "fast paths: raw_publish; raw_intake off (DYNAMIXEL_HANDLER_FAST_PATH=raw_publish): commands go "
                   "through rclpy message objects; detached_intake off",
}


def _pulses(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


@pytest.mark.parametrize("choice", list(CHOICES))
def test_commands_apply_and_states_publish_on_every_path(choice):
    rig = Rig({1: X, 2: X540}, env={FAST_ENV: choice})
    try:
        line = rig.wait_log("[INFO]", "fast paths" if choice != "none" else "public rclpy API only")
        assert CHOICES[choice] in line, line

        # a command on its own topic: both goals in the registers, both servos there in the states
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1, 2], position_deg=[40.0, -25.0]))
        rig.wait(lambda: [rig.sim.servo(i).read("goal_position") for i in (1, 2)] == [_pulses(40), _pulses(-25)],
                 what="goal positions in the registers")
        rig.wait(lambda: abs(rig.debug_of(1)["position"] - 40) < 0.5 and abs(rig.debug_of(2)["position"] + 25) < 0.5,
                 timeout=15, what="/dynamixel/debug at the goals")
        rig.wait(lambda: (rig.state_of("present", "position_deg", 1) or 0) > 39.5, what="/dynamixel/states at the goal")

        # the same in a bundle, and a shortcut: torque off for ID 2
        bundle = DxlCommandsX()
        bundle.position_control.id_list = [1]
        bundle.position_control.position_deg = [-10.0]
        rig.publish("/dynamixel/commands/x", bundle)
        rig.wait(lambda: rig.sim.servo(1).read("goal_position") == _pulses(-10), what="the bundle's goal")
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[2]))
        rig.wait(lambda: rig.sim.servo(2).read("torque_enable") == 0, what="torque off by the shortcut")
        rig.wait(lambda: not rig.debug_of(2)["torque"], what="torque off in /dynamixel/debug")
    finally:
        assert rig.close() == 0
