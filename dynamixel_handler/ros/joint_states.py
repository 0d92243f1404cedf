"""``joint_states`` (sensor_msgs/JointState) for the servos mapped to joint names.

Published on the loop thread right after each read of the present position, stamped with the
read time, so robot_state_publisher, rviz and MoveIt see the servos as joints: position [rad],
velocity [rad/s] and effort = present current [A], each with the joint's direction applied.
"""
from __future__ import annotations

from sensor_msgs.msg import JointState

from ..core.handler import StepReport
from ..joints import LiveJoints, read_joints, unhandled
from .convert import f64, stamp_of
from .lean import lean_publisher


class JointStatePublisher:
    """Loop hook: one JointState per present-position read."""

    def __init__(self, node, joints: LiveJoints) -> None:
        self.node = node
        self.joints = joints
        self.pub = lean_publisher(node, JointState, "joint_states", 10)
        self._checked_version = -1

    def __call__(self, report: StepReport) -> None:
        if "position" not in report.present:
            return
        table = self.node.handler.table
        if self._checked_version != table.version:
            self._checked_version = table.version
            missing = unhandled(self.joints.map, table.ids)
            if missing:
                self.node.get_logger().warning(
                    f"joint_states: joints {missing} map to servos that are not handled: left out")
        reading = read_joints(self.joints.map, table)
        msg = JointState()
        msg.header.stamp = stamp_of(self.node.ros_time(report.stamp))  # the node's clock (use_sim_time)
        msg.name = reading.names
        msg.position = f64(reading.position_rad)
        msg.velocity = f64(reading.velocity_rad_s)
        msg.effort = f64(reading.effort_a)
        self.pub.publish(msg)


def attach(node) -> JointStatePublisher | None:
    """The hook when ``joint_state.use`` is true (the mapping is validated at parameter load)."""
    use = node.settings.ros.joint_state_use and node.joints is not None  # never None with it (ConfigError instead)
    return JointStatePublisher(node, node.joints) if use else None
