"""set_torque / move_to services and the move_joints action, through real rclpy on the virtual bus."""
from __future__ import annotations

import threading
import time

import pytest
from rclpy.action import ActionClient

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.srv import MoveTo, SetTorque

from support.rig import X540, Rig, X


@pytest.fixture(scope="module")
def rig():
    # pan = ID 1 as is; tilt = ID 2 mounted the other way round, zero at servo angle 10 deg; a 16 ms
    # latency timer, so a servo that answers again is heard within a move's grace on a loaded host too
    r = Rig({1: X, 2: X540}, "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]",
            "joint_state.directions:=[1, -1]", "joint_state.offsets_deg:=[0.0, 10.0]", "latency_timer:=16")
    yield r
    assert r.close() == 0


def _call(rig: Rig, srv_type, name: str, request, timeout: float = 30.0):
    return rig.call(srv_type, name, request, timeout)


def _deg(rig: Rig, dxl_id: int) -> float:
    servo = rig.sim.servo(dxl_id)
    return (servo.read("present_position") - servo.model.position_zero_pulse) * servo.model.position_deg_per_pulse


def test_set_torque_by_joint_name_and_by_id(rig):
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(joint_names=["tilt"], enable=False))
    assert res.success, res.message
    assert rig.sim.servo(2).read("torque_enable") == 0 and rig.sim.servo(1).read("torque_enable") == 1
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[2], enable=True))
    assert res.success, res.message
    assert rig.sim.servo(2).read("torque_enable") == 1
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(joint_names=["elbow"], enable=False))
    assert not res.success and "unknown joint 'elbow'" in res.message
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1, 7], enable=False))
    assert not res.success and "IDs [7] are not handled" in res.message
    assert rig.sim.servo(1).read("torque_enable") == 1  # nothing changed


def test_move_to_waits_until_the_servo_arrives(rig):
    start = _deg(rig, 2)
    target_joint = -40.0  # tilt: servo angle = -1 * -40 + 10 = 50 deg
    assert abs(start - 50.0) > 30.0
    req = MoveTo.Request(joint_names=["tilt"], positions_deg=[target_joint], profile_vel_deg_s=90.0, wait=True,
                         tolerance_deg=0.5, timeout_s=10.0)
    res = _call(rig, MoveTo, "/dynamixel/move_to", req)
    assert res.success and res.reached, res.message
    assert abs(_deg(rig, 2) - 50.0) <= 0.5  # the simulated servo is there when the answer comes
    assert abs(res.positions_deg[0] - target_joint) <= 0.5  # reported in the joint's frame

    # without wait: the answer comes at once, the servo still on its way
    req = MoveTo.Request(ids=[2], positions_deg=[-20.0], profile_vel_deg_s=30.0, wait=False)
    res = _call(rig, MoveTo, "/dynamixel/move_to", req)
    assert res.success and not res.reached, res.message
    assert abs(_deg(rig, 2) - -20.0) > 5.0
    rig.wait(lambda: abs(_deg(rig, 2) - -20.0) < 0.5, timeout=15, what="the servo arriving after all")


def test_move_to_refuses_what_cannot_move_and_times_out_on_a_stuck_servo(rig):
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], joint_names=["pan"], positions_deg=[1.0]))
    assert not res.success and "not both" in res.message
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], positions_deg=[1.0, 2.0]))
    assert not res.success and "2 positions for 1 servos" in res.message
    _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1], enable=False))
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], positions_deg=[30.0], wait=True))
    assert not res.success and "torque is off on IDs [1]" in res.message
    _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1], enable=True))

    servo = rig.sim.servo(1)
    servo.pin("present_position", servo.read("present_position"))  # held by an obstacle
    try:
        res = _call(rig, MoveTo, "/dynamixel/move_to",
                    MoveTo.Request(ids=[1], positions_deg=[_deg(rig, 1) + 45.0], wait=True, timeout_s=1.0))
    finally:
        servo.pin("present_position", None)
    assert not res.success and not res.reached
    assert "timed out: ID 1 45.0 deg away" in res.message

    rig.sim.set_silent(2, True)
    try:
        res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[2], positions_deg=[0.0], wait=True))
    finally:
        rig.sim.set_silent(2, False)
    assert not res.success
    assert "do not answer" in res.message or "stopped answering" in res.message
    rig.wait(lambda: all(rig.debug[-1].status.ping), what="ID 2 answering again")


def test_a_servo_that_missed_reads_is_given_time_to_answer_before_a_move_is_refused(rig):
    # a loaded host or a noisy bus can cost a read or two: the move waits briefly for the servo
    rig.sim.set_silent(1, True)
    back = threading.Timer(0.15, rig.sim.set_silent, args=(1, False))  # answers again 0.15 s after the request
    try:
        rig.wait(lambda: not rig.debug_of(1)["ping"], what="ID 1 silent")
        target = _deg(rig, 1) + 20.0
        back.start()
        res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1], positions_deg=[target], wait=True,
                                                                     tolerance_deg=0.5, timeout_s=10.0))
    finally:
        back.cancel()
        rig.sim.set_silent(1, False)
    assert res.success and res.reached, res.message
    assert abs(_deg(rig, 1) - target) <= 0.5


def test_move_joints_streams_feedback_can_be_cancelled_and_reports_its_result(rig):
    with rig._lock:
        client = ActionClient(rig.node, MoveJoints, "/dynamixel/move_joints")
    assert client.wait_for_server(timeout_sec=10)
    feedback: list[MoveJoints.Feedback] = []

    def send(goal: MoveJoints.Goal):
        fut = rig.locked(client.send_goal_async, goal, feedback_callback=lambda m: feedback.append(m.feedback))
        rig.wait(fut.done, what="the goal accepted")
        handle = fut.result()
        assert handle.accepted
        return handle

    # a slow move, cancelled on the way: the servo stops where it is
    start = _deg(rig, 1)
    handle = send(MoveJoints.Goal(joint_names=["pan"], positions_deg=[start + 120.0], velocity_limit_deg_s=40.0,
                                  timeout_s=20.0))
    rig.wait(lambda: len(feedback) >= 3, what="feedback on the way")
    assert start < feedback[-1].positions_deg[0] < start + 120.0
    assert feedback[-1].remaining_deg[0] < feedback[0].remaining_deg[0]
    cancel = rig.locked(handle.cancel_goal_async)
    rig.wait(cancel.done, what="the cancel answer")
    result_future = rig.locked(handle.get_result_async)
    rig.wait(result_future.done, what="the result after cancel")
    result = result_future.result().result
    assert result.status == MoveJoints.Result.CANCELED, result.message
    stopped = _deg(rig, 1)
    assert start + 1.0 < stopped < start + 110.0
    time.sleep(0.5)
    assert abs(_deg(rig, 1) - stopped) < 10.0  # settles where it was stopped, does not finish the move

    # a move to completion
    feedback.clear()
    handle = send(MoveJoints.Goal(ids=[1, 2], positions_deg=[0.0, 15.0], tolerance_deg=0.5, timeout_s=20.0))
    result_future = rig.locked(handle.get_result_async)
    rig.wait(result_future.done, timeout=25, what="the result")
    result = result_future.result().result
    assert result.status == MoveJoints.Result.REACHED, result.message
    assert abs(_deg(rig, 1)) <= 0.5 and abs(_deg(rig, 2) - 15.0) <= 0.5
    assert feedback and len(feedback[-1].positions_deg) == 2

    # an unknown joint ends at once with ERROR
    handle = send(MoveJoints.Goal(joint_names=["nose"], positions_deg=[1.0]))
    result_future = rig.locked(handle.get_result_async)
    rig.wait(result_future.done, what="the error result")
    result = result_future.result().result
    assert result.status == MoveJoints.Result.ERROR and "unknown joint 'nose'" in result.message
