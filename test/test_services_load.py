"""set_torque / move_to / move_joints under abuse, through real rclpy clients on the virtual bus:
repeated or too many servos are refused at once with one short line, and every request gets its
answer in time however many wait at once (a waiting call holds no executor thread)."""
from __future__ import annotations

import time

import pytest
from rclpy.action import ActionClient
from rclpy.qos import QoSProfile, ReliabilityPolicy

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.srv import MoveTo, SetTorque

from support.rig import X540, Rig, X

#: the test's clients keep every answer of a burst (a client's own queue, as the node's)
DEEP = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
WRITE, TORQUE_ENABLE = 0x03, 64  # X series
#: generous bound for a loaded host, on top of a request's own timeout [s]
SLACK_S = 6.0


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540}, "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]")
    yield r
    assert r.close() == 0


def _client(rig: Rig, srv_type, name: str):
    with rig._lock:
        client = rig.node.create_client(srv_type, name, qos_profile=DEEP)
    assert client.wait_for_service(timeout_sec=10)
    return client


def _call(rig: Rig, srv_type, name: str, request, timeout: float = 30.0):
    future = _client(rig, srv_type, name).call_async(request)
    rig.wait(future.done, timeout=timeout, what=f"the answer of {name}")
    return future.result()


def _deg(rig: Rig, dxl_id: int) -> float:
    servo = rig.sim.servo(dxl_id)
    return (servo.read("present_position") - servo.model.position_zero_pulse) * servo.model.position_deg_per_pulse


def _torque_writes(rig: Rig) -> int:
    return sum(1 for e in rig.transactions() if e.instruction == WRITE and e.address == TORQUE_ENABLE)


def _torque_on(rig: Rig) -> None:
    """Each test starts with both servos' torque on, whatever the one before left."""
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1, 2], enable=True))
    assert res.success, res.message


def _service_lines(rig: Rig, mark: int) -> list[str]:
    return [line for line in rig.log_since(mark).splitlines()
            if any(k in line for k in ("set_torque:", "move_to:", "move_joints:"))]


def test_a_servo_named_twice_or_more_servos_than_handled_are_refused_at_once_in_one_short_line(rig):
    mark = rig.mark()
    torque_writes = _torque_writes(rig)
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1] * 1000, enable=False))
    assert not res.success and "more than once" in res.message, res.message
    assert len(res.message) < 200, res.message
    assert rig.sim.servo(1).read("torque_enable") == 1  # nothing changed
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(joint_names=["pan", "tilt", "pan"]))
    assert not res.success and "more than once" in res.message and "pan" in res.message, res.message
    res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[1, 2, 3], enable=False))
    assert not res.success and "3 servos named, 2 handled" in res.message, res.message
    assert rig.sim.servo(1).read("torque_enable") == 1 and rig.sim.servo(2).read("torque_enable") == 1

    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[1] * 10000, positions_deg=[1.5] * 10000))
    assert not res.success and len(res.message) < 200, res.message[:300]
    res = _call(rig, MoveTo, "/dynamixel/move_to",
                MoveTo.Request(ids=list(range(300, 10300)), positions_deg=[1.5] * 10000))
    assert not res.success and len(res.message) < 200, res.message[:300]
    res = _call(rig, MoveTo, "/dynamixel/move_to", MoveTo.Request(joint_names=["x" * 100_000], positions_deg=[1.0]))
    assert not res.success and "unknown joint" in res.message and len(res.message) < 300, res.message[:400]

    with rig._lock:
        client = ActionClient(rig.node, MoveJoints, "/dynamixel/move_joints", goal_service_qos_profile=DEEP,
                              result_service_qos_profile=DEEP, cancel_service_qos_profile=DEEP)
    assert client.wait_for_server(timeout_sec=10)
    fut = rig.locked(client.send_goal_async, MoveJoints.Goal(ids=[2] * 10000, positions_deg=[3.0] * 10000))
    rig.wait(fut.done, what="the goal answer")
    result_future = rig.locked(fut.result().get_result_async)
    rig.wait(result_future.done, what="the result")
    result = result_future.result().result
    assert result.status == MoveJoints.Result.ERROR and "more than once" in result.message, result.message[:300]
    assert len(result.message) < 200, result.message[:300]

    lines = _service_lines(rig, mark)
    assert lines and all(len(line) < 300 for line in lines), [line[:300] for line in lines]
    # refused before any bus work: no torque write went out for the thousand repeats
    assert _torque_writes(rig) == torque_writes


def test_many_waiting_moves_are_all_answered_in_time_and_other_calls_meanwhile(rig):
    _torque_on(rig)
    servo = rig.sim.servo(1)
    servo.pin("present_position", servo.read("present_position"))  # held: the moves never arrive
    try:
        client = _client(rig, MoveTo, "/dynamixel/move_to")
        target = _deg(rig, 1) + 30.0
        sent = time.monotonic()
        futures = [client.call_async(MoveTo.Request(ids=[1], positions_deg=[target], wait=True, timeout_s=3.0))
                   for _ in range(60)]
        time.sleep(0.5)
        # a waiting move holds nothing others need: another call is answered meanwhile
        res = _call(rig, SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[2], enable=True), timeout=SLACK_S)
        assert res.success, res.message
        rig.wait(lambda: all(f.done() for f in futures), timeout=3.0 + SLACK_S,
                 what=f"every answer ({sum(f.done() for f in futures)} of {len(futures)} came)")
        assert time.monotonic() - sent < 3.0 + SLACK_S
    finally:
        servo.pin("present_position", None)
    answers = [f.result() for f in futures]
    assert all(not a.success and not a.reached for a in answers)
    preempted = [a for a in answers if "preempted" in a.message]
    timed_out = [a for a in answers if "timed out" in a.message]
    # a later move on the same servo ends the earlier waiting one: all but one are preempted
    assert len(preempted) == len(answers) - 1 and len(timed_out) == 1, {a.message for a in answers}


def test_many_move_joints_goals_are_all_accepted_and_answered_the_last_one_moves(rig):
    _torque_on(rig)
    with rig._lock:
        client = ActionClient(rig.node, MoveJoints, "/dynamixel/move_joints", goal_service_qos_profile=DEEP,
                              result_service_qos_profile=DEEP, cancel_service_qos_profile=DEEP)
    assert client.wait_for_server(timeout_sec=10)
    target = _deg(rig, 2) + 20.0
    goals = [rig.locked(client.send_goal_async, MoveJoints.Goal(ids=[2], positions_deg=[target], tolerance_deg=0.5,
                                                                 timeout_s=10.0))
             for _ in range(40)]
    rig.wait(lambda: all(g.done() for g in goals), timeout=SLACK_S,
             what=f"every goal answer ({sum(g.done() for g in goals)} of {len(goals)} came)")
    assert all(g.result().accepted for g in goals)
    results = [rig.locked(g.result().get_result_async) for g in goals]
    rig.wait(lambda: all(r.done() for r in results), timeout=10.0 + SLACK_S,
             what=f"every result ({sum(r.done() for r in results)} of {len(results)} came)")
    outcomes = [r.result().result for r in results]
    # a goal ends preempted by a later one, or reached (the servo was there before a later one came);
    # goals taken at once by several executor threads need not be taken in the order sent
    reached = [o for o in outcomes if o.status == MoveJoints.Result.REACHED]
    preempted = [o for o in outcomes if o.status == MoveJoints.Result.ERROR and "preempted" in o.message]
    assert reached and len(reached) + len(preempted) == len(outcomes), {o.message for o in outcomes}
    assert abs(_deg(rig, 2) - target) <= 0.5


def test_a_later_move_preempts_an_earlier_one_on_the_same_servo_only(rig):
    _torque_on(rig)
    slow = _client(rig, MoveTo, "/dynamixel/move_to")
    start1, start2 = _deg(rig, 1), _deg(rig, 2)
    first = slow.call_async(MoveTo.Request(ids=[1, 2], positions_deg=[start1 + 90.0, start2 + 10.0],
                                           profile_vel_deg_s=20.0, wait=True, timeout_s=20.0))
    rig.wait(lambda: abs(_deg(rig, 1) - start1) > 2.0, what="the first move under way")
    other = slow.call_async(MoveTo.Request(joint_names=["tilt"], positions_deg=[start2 - 10.0], wait=False))
    rig.wait(other.done, what="the move of ID 2")
    assert other.result().success, other.result().message
    rig.wait(first.done, timeout=SLACK_S, what="the first move answering")
    res = first.result()
    assert not res.success and "preempted" in res.message and "ID 2" in res.message, res.message
    # ID 1 goes on to the goal the first move gave it: nothing it was commanded is lost
    rig.wait(lambda: abs(_deg(rig, 1) - (start1 + 90.0)) < 1.0, timeout=15, what="ID 1 arriving")
    rig.wait(lambda: abs(_deg(rig, 2) - (start2 - 10.0)) < 1.0, timeout=15, what="ID 2 at the later goal")


def test_a_flood_of_refused_requests_logs_at_most_a_line_a_second_per_cause(rig):
    client = _client(rig, SetTorque, "/dynamixel/set_torque")
    mark = rig.mark()
    start = time.monotonic()
    futures = [client.call_async(SetTorque.Request(ids=[2, 2], enable=False)) for _ in range(40)]
    rig.wait(lambda: all(f.done() for f in futures), timeout=SLACK_S, what="every answer")
    assert all(not f.result().success and "more than once" in f.result().message for f in futures)
    time.sleep(0.2)
    seconds = time.monotonic() - start
    lines = [line for line in _service_lines(rig, mark) if "more than once" in line]
    assert 1 <= len(lines) <= seconds + 1, lines
    assert rig.sim.servo(2).read("torque_enable") == 1
