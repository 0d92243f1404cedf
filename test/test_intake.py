"""Command topics taken by the loop thread (dynamixel_handler/ros/intake.py), seen from outside:
commands on different topics apply in the order they were published, bytes that are not a
message are refused with a log line and the node goes on, and the command subscriptions are
still ordinary subscriptions of the node in the ROS graph."""
from __future__ import annotations

import time

import pytest

from dynamixel_handler_msgs.msg import DxlCommandsX, DynamixelControlXPosition, DynamixelShortcut

from support.rig import Rig, X

X_DEG, X_ZERO = 360.0 / 4096, 2048  # e-Manual: 4096 pulses a turn, 0 deg at 2048


def pulses(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


@pytest.fixture(scope="module")
def rig():
    # a slow loop (250 ms), so that commands published back to back land in one step
    r = Rig({1: X, 2: X}, "loop_rate:=4")
    yield r
    assert r.close() == 0


def goal_register(rig: Rig, dxl_id: int) -> int:
    return rig.sim.servo(dxl_id).read("goal_position")


def single(deg: float) -> DynamixelControlXPosition:
    return DynamixelControlXPosition(id_list=[1], position_deg=[deg])


def bundle(deg: float) -> DxlCommandsX:
    msg = DxlCommandsX()
    msg.position_control = single(deg)
    return msg


def settle(rig: Rig, deg: float) -> None:
    rig.wait(lambda: goal_register(rig, 1) == pulses(deg), timeout=10, what=f"goal register at {deg} deg")


def test_commands_on_different_topics_apply_in_publish_order(rig):
    control, commands = "/dynamixel/command/x/position_control", "/dynamixel/commands/x"
    rig.publish(control, single(5.0))  # matches both publishers before the timed part
    rig.publish(commands, bundle(5.0))
    settle(rig, 5.0)
    for order in ((control, commands, control), (commands, control, commands)):
        for k, topic in enumerate(order):
            deg = 10.0 * (k + 1)
            rig.publish(topic, single(deg) if topic == control else bundle(deg))
        settle(rig, 30.0)  # the last one published wins, whatever topic carried it
        time.sleep(0.6)    # two more loops: nothing taken later overrides it
        assert goal_register(rig, 1) == pulses(30.0)
        rig.publish(control, single(5.0))
        settle(rig, 5.0)


def test_bytes_that_are_no_message_are_refused_and_the_node_goes_on(rig):
    mark = rig.mark()
    garbage = rig.node.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 10)
    rig.wait(lambda: garbage.get_subscription_count() > 0, what="the handler's subscription")
    # a sequence claiming 4 billion IDs in a 12-byte message
    garbage.publish(b"\x00\x01\x00\x00\xff\xff\xff\xff\x01\x00\x02\x00")
    line = rig.wait_log("commands/x", "dropped", since=mark)
    assert "decode" in line
    rig.publish("/dynamixel/command/x/position_control", single(-20.0))
    settle(rig, -20.0)
    assert rig.node_proc.proc.poll() is None


def test_command_subscriptions_are_listed_in_the_graph(rig):
    topics = dict(rig.node.get_subscriber_names_and_types_by_node("dynamixel_handler", "/"))
    assert topics["/dynamixel/commands/x"] == ["dynamixel_handler_msgs/msg/DxlCommandsX"]
    assert topics["/dynamixel/shortcut"] == ["dynamixel_handler_msgs/msg/DynamixelShortcut"]
    assert "/dynamixel/command/x/position_control" in topics
    # and they are live: a shortcut arrives
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_off", id_list=[2]))
    rig.wait(lambda: rig.sim.servo(2).read("torque_enable") == 0, what="ID 2 torque off")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_on", id_list=[2]))
    rig.wait(lambda: rig.sim.servo(2).read("torque_enable") == 1, what="ID 2 torque on")
    assert "Traceback" not in rig.log_since(mark)
