"""The E-stop through the real node on the virtual bus: ``dynamixel/e_stop`` (Bool),
``dynamixel/set_e_stop`` (SetBool) and the latched ``dynamixel/e_stop_state``; every servo holds in
its mode, every door that would move one refuses, running moves and trajectories end, a release
moves nothing; ``safety/on_hardware_error: hold_all``."""
from __future__ import annotations

import math
import time

import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.msg import (
    DynamixelControlXCurrent,
    DynamixelControlXPosition,
    DynamixelControlXVelocity,
    DynamixelShortcut,
)
from dynamixel_handler_msgs.srv import MoveTo, SetTorque

from support.rig import SYNC_WRITE, X540, Rig, X

OVERLOAD = 0x20
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
JOINTS = ("joint_state.use:=true", "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]")


def _call(rig: Rig, srv_type, name: str, request, timeout: float = 30.0):
    return rig.call(srv_type, name, request, timeout)


def _deg(rig: Rig, dxl_id: int, item: str = "present_position") -> float:
    servo = rig.sim.servo(dxl_id)
    return (servo.read(item) - servo.model.position_zero_pulse) * servo.model.position_deg_per_pulse


def _at_rest(rig: Rig, dxl_id: int, still_s: float = 0.3, timeout: float = 15.0) -> int:
    """Wait until the servo's present position has not changed for ``still_s``; that position."""
    seen = {"value": None, "since": time.monotonic()}

    def still() -> bool:
        value = rig.sim.servo(dxl_id).read("present_position")
        if value != seen["value"]:
            seen["value"], seen["since"] = value, time.monotonic()
        return time.monotonic() - seen["since"] >= still_s
    rig.wait(still, timeout=timeout, what=f"ID {dxl_id} at rest")
    return int(seen["value"])


def _state_listener(rig: Rig) -> list[bool]:
    got: list[bool] = []
    with rig._lock:
        rig.node.create_subscription(Bool, "/dynamixel/e_stop_state", lambda m: got.append(bool(m.data)), LATCHED)
    return got


def _set(rig: Rig, engage: bool):
    return _call(rig, SetBool, "/dynamixel/set_e_stop", SetBool.Request(data=engage))


def _writes_to(rig: Rig, since: int, item: str, dxl_id: int) -> int:
    """Sync writes after log entry ``since`` that carry ``item`` for ``dxl_id``."""
    address = rig.sim.servo(dxl_id).model.item(item).address
    count = 0
    for e in rig.sim.log[since:]:
        if e.instruction == SYNC_WRITE and e.address <= address < e.address + e.length:
            count += any(e.params[k] == dxl_id for k in range(4, len(e.params), 1 + e.length))
    return count


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: X}, *JOINTS, "latency_timer:=16")
    yield r
    assert r.close() == 0


def test_engaging_holds_each_servo_in_its_mode_and_a_release_moves_nothing(rig):
    states = _state_listener(rig)
    rig.wait(lambda: states == [False], what="the latched state: released")
    # ID 1 on a slow move in position mode, ID 2 turning in velocity mode, ID 3 in current mode
    start = _deg(rig, 1)
    target = -120.0 if start > 0.0 else 120.0  # far from where it is, within its limits (±180°)
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1], position_deg=[target], profile_vel_deg_s=[20.0]))
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[30.0]))
    rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[3], current_ma=[20.0]))
    rig.wait(lambda: rig.sim.servo(2).read("operating_mode") == 1 and rig.sim.servo(2).read("goal_velocity") > 0,
             what="ID 2 turning")
    rig.wait(lambda: rig.sim.servo(3).read("operating_mode") == 0 and rig.sim.servo(3).read("goal_current") > 0,
             what="ID 3 in current mode with a goal")
    rig.wait(lambda: abs(_deg(rig, 1) - start) > 5.0, what=f"ID 1 on its way to {target}° (at {_deg(rig, 1):.1f}°)")
    moving = rig.sim.servo(1).read("present_velocity") != 0

    mark = rig.mark()
    rig.publish("/dynamixel/e_stop", Bool(data=True))
    rig.wait(lambda: states[-1:] == [True], what="the latched state: engaged")
    line = rig.wait_log("E-stop engaged (dynamixel/e_stop)", since=mark)
    assert "3 servo(s) hold" in line, line
    # held: ID 1's goal is where it was when the stop came, IDs 2 and 3 have goal 0; torque still on
    rig.wait(lambda: rig.sim.servo(2).read("goal_velocity") == 0 and rig.sim.servo(3).read("goal_current") == 0,
             what="goal velocity and current 0")
    held = _at_rest(rig, 1)
    if moving:  # caught on its way: it stopped short of its goal
        assert abs(_deg(rig, 1) - target) > 1.0, "ID 1 went on to its goal"
    assert abs(rig.sim.servo(1).read("goal_position") - held) <= 20, rig.sim.servo(1).read("goal_position")
    assert all(rig.sim.servo(i).read("torque_enable") == 1 for i in (1, 2, 3))  # nothing fell
    assert [rig.sim.servo(i).read("operating_mode") for i in (1, 2, 3)] == [3, 1, 0]  # no mode switched

    # every door that would move a servo refuses while engaged
    log_at = len(rig.sim.log)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[0.0]))
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[1], velocity_deg_s=[50.0]))
    rig.wait_log("E-stop engaged (dynamixel/e_stop):", "refused", since=mark)
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], positions_deg=[0.0]))
    assert not res.success and "E-stop is engaged" in res.message, res.message
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[3], enable=False))
    assert res.success, res.message  # torque off moves nothing: taken
    assert rig.sim.servo(3).read("torque_enable") == 0
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[3], enable=True))
    assert not res.success and "E-stop is engaged" in res.message, res.message
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_on", id_list=[3]))
    rig.wait_log("torque on refused", since=mark)
    rig.publish("/joint_commands", JointState(name=["pan"], position=[0.0]))  # ID 1: no goal written (below)
    with rig._lock:
        mj = ActionClient(rig.node, MoveJoints, "/dynamixel/move_joints")
    assert mj.wait_for_server(timeout_sec=10)
    sent = rig.locked(mj.send_goal_async, MoveJoints.Goal(ids=[1], positions_deg=[0.0]))
    rig.wait(sent.done, what="the move_joints goal answered")
    ended = rig.locked(sent.result().get_result_async)
    rig.wait(ended.done, what="the move_joints result")
    assert ended.result().result.status == MoveJoints.Result.ERROR
    assert "E-stop is engaged" in ended.result().result.message, ended.result().result.message
    rig.fresh_states(count=3)
    assert rig.sim.servo(3).read("torque_enable") == 0
    assert rig.sim.servo(1).read("operating_mode") == 3 and _writes_to(rig, log_at, "goal_position", 1) == 0
    # the position command and joint_commands (which reaches the servo as position control): one line a
    # second for both, so one or two lines
    assert 1 <= len([ln for ln in rig.log_since(mark).splitlines() if "x/position_control refused" in ln]) <= 2

    # released: nothing moves by itself, and commands are taken again
    log_at = len(rig.sim.log)
    res = _set(rig, False)
    assert res.success and "released" in res.message, res.message
    rig.wait(lambda: states[-1:] == [False], what="the latched state: released")
    rig.fresh_states(count=5)
    assert _at_rest(rig, 1) == held and rig.sim.servo(2).read("goal_velocity") == 0
    assert _writes_to(rig, log_at, "goal_position", 1) == 0
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], positions_deg=[_deg(rig, 1) - 10.0],
                                                                   profile_vel_deg_s=90.0, wait=True, timeout_s=10.0))
    assert res.success and res.reached, res.message


def test_a_trajectory_and_a_waiting_move_end_at_once_and_new_ones_are_refused(rig):
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1, 2], position_deg=[0.0, 0.0]))
    rig.wait(lambda: all(rig.sim.servo(i).read("operating_mode") == 3 for i in (1, 2)), what="position mode")
    with rig._lock:
        fjt = ActionClient(rig.node, FollowJointTrajectory, "/dynamixel_handler/follow_joint_trajectory")
    assert fjt.wait_for_server(timeout_sec=10)
    far = -90.0 if _deg(rig, 1) > 0.0 else 90.0  # within the limits (±180°) from wherever it is
    goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=["pan"], points=[
        JointTrajectoryPoint(positions=[math.radians(far)], time_from_start=Duration(sec=6))]))
    sent = rig.locked(fjt.send_goal_async, goal)
    rig.wait(sent.done, what="the goal accepted")
    handle = sent.result()
    assert handle.accepted
    result = rig.locked(handle.get_result_async)
    start = _deg(rig, 1)
    rig.wait(lambda: abs(_deg(rig, 1) - start) > 3.0, what="the trajectory under way")
    with rig._lock:
        waiting = rig.node.create_client(MoveTo, "/dynamixel/move_to")
    assert waiting.wait_for_service(timeout_sec=10)
    target = -90.0 if _deg(rig, 2) > 0.0 else 90.0
    move = waiting.call_async(MoveTo.Request(ids=[2], positions_deg=[target], profile_vel_deg_s=10.0,
                                             wait=True, timeout_s=20.0))
    # the move taken by the node: its goal on the servo (a moving shaft alone may still be the
    # position command above, the move's request not yet taken: then the E-stop refuses it instead)
    rig.wait(lambda: abs(_deg(rig, 2, "goal_position") - target) < 1.0, what="the move's goal written")

    res = _set(rig, True)
    assert res.success and "engaged" in res.message, res.message
    rig.wait(result.done, timeout=5, what="the trajectory's result")
    assert "E-stop was engaged" in result.result().result.error_string, result.result().result
    rig.wait(move.done, timeout=5, what="the waiting move's answer")
    assert not move.result().success and "E-stop was engaged" in move.result().message, move.result().message
    _at_rest(rig, 1)
    _at_rest(rig, 2)

    sent = rig.locked(fjt.send_goal_async, goal)
    rig.wait(sent.done, what="the goal answered")
    handle = sent.result()
    if handle.accepted:  # refused with its reason in the result
        result = rig.locked(handle.get_result_async)
        rig.wait(result.done, what="the refused goal's result")
        assert "E-stop is engaged" in result.result().result.error_string, result.result().result
    assert _set(rig, False).success


def test_the_state_is_latched_for_a_late_subscriber_and_in_diagnostics(rig):
    from diagnostic_msgs.msg import DiagnosticArray
    assert _set(rig, True).success
    states = _state_listener(rig)  # subscribes after the change
    rig.wait(lambda: states == [True], what="the latched state: engaged")
    diags: list = []
    with rig._lock:
        rig.node.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    def engaged_said() -> bool:
        return any("bus" in s.name and s.level != b"\x00" and
                   {v.key: v.value for v in s.values}.get("e-stop", "").startswith("engaged")
                   for d in diags for s in d.status)
    rig.wait(engaged_said, timeout=10, what="the bus status saying the E-stop is engaged")
    bus = next(s for d in reversed(diags) for s in d.status if "bus" in s.name)
    assert {v.key: v.value for v in bus.values}["e-stop"] == "engaged: dynamixel/set_e_stop"
    assert _set(rig, False).success
    rig.wait(lambda: states[-1:] == [False], what="released")
