"""follow_joint_trajectory under a crowd: while MAX_JOBS goals wait (as many as the services take),
the next goal is rejected at once, with one line, and a client hears so instead of timing out;
once a goal ends, goals are taken again. A real rclpy action server and client in this process;
the follower is never reached (the goals are refused before they run)."""
from __future__ import annotations

import importlib.util
import os
import shutil
import threading
import time

import pytest

needs_ros = pytest.mark.skipif(importlib.util.find_spec("control_msgs") is None or shutil.which("dynamixel_handler") is None,
                               reason="needs the ROS environment and control_msgs: source env.sh")


class _Commands:
    """What the action takes of the node's joint commands at construction: the follower."""

    follower = None


@needs_ros
def test_a_full_queue_rejects_the_next_goal_at_once_with_one_line():
    import rclpy
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient, GoalResponse
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from dynamixel_handler.commands.moves import MAX_JOBS
    from dynamixel_handler.logs import Throttle
    from dynamixel_handler.ros.trajectory_action import TrajectoryAction

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    node = Node("crowd_server", context=context)
    client_node = Node("crowd_client", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(client_node)
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
    spinner = threading.Thread(target=spin, daemon=True)
    try:
        action = TrajectoryAction(node, _Commands())
        lines: list[str] = []
        action.warn = Throttle(lines.append)
        action.waiting = MAX_JOBS
        client = ActionClient(client_node, FollowJointTrajectory, "/crowd_server/follow_joint_trajectory")
        spinner.start()
        assert client.wait_for_server(timeout_sec=20)
        sent = client.send_goal_async(FollowJointTrajectory.Goal())
        end = time.monotonic() + 20
        while not sent.done() and time.monotonic() < end:
            time.sleep(0.01)
        assert sent.done() and not sent.result().accepted
        assert lines == [f"follow_joint_trajectory: busy: {MAX_JOBS} goals are waiting already: goal rejected "
                         "(try again later)"]
        assert action.waiting == MAX_JOBS  # a rejected goal takes no place
        action.waiting = MAX_JOBS - 1  # one ended: the next is taken (counted until it ends)
        assert action._accept(None) == GoalResponse.ACCEPT and action.waiting == MAX_JOBS
        assert action._accept(None) == GoalResponse.REJECT and len(lines) == 1  # the same line, within a second
    finally:
        stop.set()
        if spinner.is_alive():
            spinner.join(5)
        node.destroy_node()
        client_node.destroy_node()
        rclpy.shutdown(context=context)
