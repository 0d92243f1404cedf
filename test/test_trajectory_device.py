"""follow_joint_trajectory when the bus adapter vanishes: the running goal ends at once with the
reason, new goals are refused while it is gone, and the failed writes are logged once a second.
Through the real node on the virtual bus; the adapter is unplugged with ``VirtualBus.vanish``."""
from __future__ import annotations

import time

import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from support.rig import Rig, X

R = FollowJointTrajectory.Result
ACTION = "/dynamixel_handler/follow_joint_trajectory"


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X}, "joint_state.use:=true", "joint_state.names:=[pan]", "joint_state.ids:=[1]",
            "loop_rate:=100", "baudrate:=1000000", sim_kwargs={"baudrate": 1_000_000})
    yield r
    if r.sim.vanished:
        r.sim.reappear()
    assert r.close() == 0


def goal(seconds: float, to: float) -> FollowJointTrajectory.Goal:
    return FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=["pan"], points=[JointTrajectoryPoint(
        positions=[to], time_from_start=Duration(sec=int(seconds), nanosec=int((seconds % 1) * 1e9)))]))


def send(rig: Rig, client: ActionClient, g: FollowJointTrajectory.Goal):
    fut = rig.locked(client.send_goal_async, g)
    rig.wait(fut.done, what="the goal answered")
    handle = fut.result()
    assert handle.accepted
    return handle


def result_of(rig: Rig, handle, timeout: float = 20.0):
    fut = rig.locked(handle.get_result_async)
    rig.wait(fut.done, timeout=timeout, what="the goal's result")
    return fut.result().status, fut.result().result, time.monotonic()


def test_a_vanished_device_ends_the_goal_at_once_and_refuses_new_ones(rig):
    with rig._lock:
        client = ActionClient(rig.node, FollowJointTrajectory, ACTION)
    assert client.wait_for_server(timeout_sec=10)
    rig.publish("/joint_commands", JointState(name=["pan"], position=[0.0]))
    rig.fresh_states(count=5)
    handle = send(rig, client, goal(6.0, 1.0))
    time.sleep(1.0)
    mark = rig.mark()
    rig.sim.vanish()
    lost = time.monotonic()
    status, result, ended = result_of(rig, handle)
    assert status == 6 and result.error_code != R.SUCCESSFUL  # ABORTED
    assert "gone" in result.error_string, result.error_string
    # within a loop or two of the loss (10 ms each; the bound allows for a loaded machine)
    assert ended - lost < 2.0, f"aborted {ended - lost:.2f} s after the device vanished"
    # a goal while it is gone: refused at once, saying why
    status, result, _ = result_of(rig, send(rig, client, goal(1.0, 0.5)))
    assert status == 6 and result.error_code == R.INVALID_GOAL and "gone" in result.error_string
    rig.publish("/joint_commands", JointState(name=["pan"], position=[0.3]))  # writes that cannot go out
    time.sleep(3.0)
    gone_for = time.monotonic() - lost
    lines = rig.log_since(mark).splitlines()
    writes = [line for line in lines if "sync write" in line]
    assert len(writes) <= gone_for + 2, "\n".join(writes)  # one a second at most
    rig.sim.reappear()  # (what the node does then is test_device_loss.py's)
