"""The ``joints`` block through the real node on the virtual bus: a joint with a reduction of 2, a
gripper in metres and a finger that mimics it, on every joint-level door (joint_commands,
joint_states, follow_joint_trajectory, move_to, move_joints), soft limits on each, and a block that cannot be
right stopping the node with one line. Goals are read back from the simulated servos' registers."""
from __future__ import annotations

import math
import time

import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.msg import DynamixelGoal
from dynamixel_handler_msgs.srv import MoveTo

from support.rig import SYNC_WRITE, Rig, X
from support.ros import NodeProcess, node_command

BLOCK = ("joints.elbow.ids:=[3, 4]", "joints.elbow.directions:=[1, -1]",
         "joints.wrist_pitch.coupled:=[5, 6]", "joints.wrist_pitch.row:=[0.5, 0.5]",
         "joints.wrist_roll.coupled:=[5, 6]", "joints.wrist_roll.row:=[0.5, -0.5]",
         "joints.shoulder.id:=1", "joints.shoulder.reduction:=2.0", "joints.shoulder.limits.position:=[-1.0, 1.2]",
         "joints.shoulder.limits.velocity:=3.0",
         "joints.gripper.id:=2", "joints.gripper.type:=prismatic", "joints.gripper.stroke:=[0.0, 0.04]",
         "joints.gripper.servo_deg:=[0.0, 100.0]", "joints.finger.mimic:=gripper", "joints.finger.multiplier:=0.5")
ACTION = "/dynamixel_handler/follow_joint_trajectory"
R = FollowJointTrajectory.Result


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X, 3: X, 4: X, 5: X, 6: X}, *BLOCK, "loop_rate:=100", "baudrate:=1000000", sim_kwargs={"baudrate": 1_000_000})
    yield r
    assert r.close() == 0


def servo_deg(rig: Rig, dxl_id: int, item: str = "goal_position") -> float:
    servo = rig.sim.servo(dxl_id)
    return (servo.read(item) - servo.model.position_zero_pulse) * servo.model.position_deg_per_pulse


def at_rest(rig: Rig, dxl_id: int) -> bool:
    """The servo's present position did not change for 0.2 s."""
    before = rig.sim.servo(dxl_id).read("present_position")
    time.sleep(0.2)
    return rig.sim.servo(dxl_id).read("present_position") == before


def goals_at(rig: Rig, expected: dict[int, float], what: str) -> None:
    """Wait until the servos' Goal Position registers are at ``expected`` [servo deg] (a pulse)."""
    rig.wait(lambda: all(abs(servo_deg(rig, i) - d) < 0.1 for i, d in expected.items()), timeout=15,
             what=f"{what}: goals {expected} deg")


def test_joint_commands_in_joint_units_go_through_the_reduction_and_the_stroke(rig):
    rig.publish("/joint_commands", JointState(name=["shoulder", "gripper"], position=[0.5, 0.02]))
    # shoulder: 0.5 rad of joint is 1 rad of servo (reduction 2); gripper: 2 cm of 4 is 50 of 100 deg
    goals_at(rig, {1: math.degrees(1.0), 2: 50.0}, "shoulder 0.5 rad, gripper 0.02 m")


def test_joint_states_carry_joint_units_and_the_mimic_joint(rig):
    rig.publish("/joint_commands", JointState(name=["shoulder", "gripper"], position=[-0.25, 0.01]))
    got: list[JointState] = []
    with rig._lock:
        rig.node.create_subscription(JointState, "/joint_states", got.append, 50)

    def there() -> bool:
        if not got:
            return False
        msg = got[-1]
        at = dict(zip(msg.name, msg.position))
        return (abs(at.get("shoulder", 9) + 0.25) < 0.002 and abs(at.get("gripper", 9) - 0.01) < 0.0002
                and abs(at.get("finger", 9) - 0.005) < 0.0002)

    rig.wait(there, timeout=15, what="joint_states at shoulder -0.25 rad, gripper 0.01 m, finger 0.005 m")
    rig.wait(lambda: at_rest(rig, 1), timeout=15, what="the shoulder's shaft at rest")
    seen = len(got)
    rig.wait(lambda: len(got) > seen + 1, timeout=10, what="joint states read since")
    msg = got[-1]
    # ROS hands the block over sorted, the coupled sets after the others, the mimics last
    assert list(msg.name) == ["elbow", "gripper", "shoulder", "wrist_pitch", "wrist_roll", "finger"]
    shoulder = msg.position[2]
    assert shoulder == pytest.approx(math.radians(servo_deg(rig, 1, "present_position")) / 2.0, abs=1e-9)


def _profile(rig: Rig, deg_s: float) -> None:
    """Servo 1's profile velocity set on the servo level (an earlier test's move may have set another)."""
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[1], profile_vel_deg_s=[deg_s]))
    servo = rig.sim.servo(1)
    rig.wait(lambda: abs(servo.read("profile_velocity") * servo.model.velocity_deg_s_per_pulse - deg_s) < 1.5,
             timeout=15, what=f"servo 1's profile velocity at {deg_s:g} deg/s")


def test_the_velocity_limit_caps_the_servo_s_profile_and_refuses_a_trajectory_too_fast(rig):
    servo = rig.sim.servo(1)
    _profile(rig, 0.0)  # none: as fast as the servo goes
    rig.fresh_states(count=3)
    rig.publish("/joint_commands", JointState(name=["shoulder"], position=[0.4]))
    cap = math.degrees(3.0 * 2.0)  # 3 rad/s of joint: 6 rad/s of servo (reduction 2)
    rig.wait(lambda: abs(servo.read("profile_velocity") * servo.model.velocity_deg_s_per_pulse - cap) < 1.5, timeout=15,
             what=f"profile velocity {cap:.0f} deg/s")
    _profile(rig, 100.0)  # slower than the limit: kept
    rig.fresh_states(count=3)
    rig.publish("/joint_commands", JointState(name=["shoulder"], position=[0.2]))
    goals_at(rig, {1: math.degrees(0.4)}, "shoulder at 0.2 rad")
    assert servo.read("profile_velocity") * servo.model.velocity_deg_s_per_pulse == pytest.approx(100.0, abs=1.5)
    result = _send(rig, ["shoulder"], [(0.2, [0.4]), (0.3, [0.9])])  # 5 rad/s between the two
    assert result.error_code == R.INVALID_GOAL
    assert result.error_string == "point 1: joint shoulder at 5/s is faster than its limit 3/s (joints.shoulder.limits.velocity)"


def test_a_joint_command_beyond_the_soft_limit_is_clamped_with_one_line(rig):
    mark = rig.mark()
    for _ in range(5):
        rig.publish("/joint_commands", JointState(name=["shoulder"], position=[3.0]))
    goals_at(rig, {1: math.degrees(2 * 1.2)}, "shoulder clamped at its limit 1.2 rad")
    line = "joint shoulder goal beyond its limits [-1, 1.2] (joints.shoulder.limits.position): clamped"
    rig.wait_log(line, since=mark)
    assert rig.log_since(mark).count(line) == 1  # one line a second, not one per message


def _send(rig: Rig, names, points):
    with rig._lock:
        if not hasattr(rig, "fjt"):
            rig.fjt = ActionClient(rig.node, FollowJointTrajectory, ACTION)
    assert rig.fjt.wait_for_server(timeout_sec=10)
    goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=list(names), points=[
        JointTrajectoryPoint(positions=list(p), time_from_start=Duration(sec=int(t), nanosec=int((t % 1) * 1e9)))
        for t, p in points]))
    fut = rig.locked(rig.fjt.send_goal_async, goal)
    rig.wait(fut.done, what="the goal accepted")
    handle = fut.result()
    assert handle.accepted
    res = rig.locked(handle.get_result_async)
    rig.wait(res.done, timeout=20, what="the goal's result")
    return res.result().result


def test_a_trajectory_in_joint_units_is_followed_and_a_point_beyond_the_limits_refused(rig):
    # MoveIt's path: joint units on a robot with a reduction, a gripper in metres and a paired joint
    result = _send(rig, ["shoulder", "gripper", "elbow"], [(0.4, [0.3, 0.03, 0.1]), (0.8, [0.6, 0.035, 0.2])])
    assert result.error_code == R.SUCCESSFUL, result.error_string
    goals_at(rig, {1: math.degrees(1.2), 2: 87.5, 3: math.degrees(0.2), 4: -math.degrees(0.2)},
             "the trajectory's last point")
    before = {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)}
    result = _send(rig, ["shoulder"], [(0.4, [0.5]), (0.8, [1.5])])
    assert result.error_code == R.INVALID_GOAL
    assert result.error_string.startswith("point 1: joint shoulder at 1.5 is beyond its limits [-1, 1.2]"), result.error_string
    rig.fresh_states(count=3)
    assert {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)} == before  # nothing moved


def test_move_to_by_joint_name_speaks_the_joint_s_degrees_and_refuses_the_prismatic_one(rig):
    res = rig.call(MoveTo, "/dynamixel/move_to", MoveTo.Request(joint_names=["shoulder"], positions_deg=[20.0],
                                                                 profile_vel_deg_s=200.0, wait=False))
    assert res.success, res.message
    goals_at(rig, {1: 40.0}, "shoulder at 20 deg of joint")
    res = rig.call(MoveTo, "/dynamixel/move_to", MoveTo.Request(joint_names=["shoulder"], positions_deg=[90.0]))
    assert res.success and "beyond its limits" in res.message, res.message  # clamped at 1.2 rad, said so
    goals_at(rig, {1: math.degrees(2.4)}, "shoulder at its limit")
    res = rig.call(MoveTo, "/dynamixel/move_to", MoveTo.Request(joint_names=["gripper"], positions_deg=[1.0]))
    assert not res.success and "joint gripper is prismatic" in res.message


def test_move_joints_by_joint_name_moves_and_reports_in_the_joint_s_degrees(rig):
    with rig._lock:
        client = ActionClient(rig.node, MoveJoints, "/dynamixel/move_joints")
    assert client.wait_for_server(timeout_sec=10)
    feedback: list[MoveJoints.Feedback] = []

    def result_of(goal: MoveJoints.Goal) -> MoveJoints.Result:
        fut = rig.locked(client.send_goal_async, goal, feedback_callback=lambda m: feedback.append(m.feedback))
        rig.wait(fut.done, what="the goal accepted")
        assert fut.result().accepted
        done = rig.locked(fut.result().get_result_async)
        rig.wait(done.done, timeout=25, what="the result")
        return done.result().result

    result = result_of(MoveJoints.Goal(joint_names=["shoulder"], positions_deg=[-15.0], velocity_limit_deg_s=100.0,
                                       tolerance_deg=1.0, timeout_s=20.0))
    assert result.status == MoveJoints.Result.REACHED, result.message
    goals_at(rig, {1: -30.0}, "shoulder at -15 deg of joint (reduction 2)")
    assert abs(result.positions_deg[0] + 15.0) <= 1.0, result.positions_deg  # the joint's degrees, not the servo's
    assert feedback and abs(feedback[-1].positions_deg[0]) < 40.0
    # beyond the soft limit: moved to the limit (-1.0 rad) and said so
    result = result_of(MoveJoints.Goal(joint_names=["shoulder"], positions_deg=[-80.0], velocity_limit_deg_s=200.0,
                                       tolerance_deg=1.0, timeout_s=20.0))
    assert result.status == MoveJoints.Result.REACHED and "beyond its limits" in result.message, result.message
    goals_at(rig, {1: math.degrees(-2.0)}, "shoulder at its lower limit")
    assert abs(result.positions_deg[0] - math.degrees(-1.0)) <= 1.0, result.positions_deg


def _goal_writes_of(rig: Rig, since: float, ids: set[int]) -> list[dict[int, int]]:
    """The Goal Position values of ``ids`` in each Sync Write the bus received after ``since``."""
    address = rig.sim.servo(3).model.item("goal_position").address
    out = []
    for e in rig.sim.log:
        if e.time < since or e.instruction != SYNC_WRITE or not e.address <= address < e.address + e.length:
            continue
        values = {}
        for k in range(4, len(e.params), 1 + e.length):
            data = e.params[k + 1 + address - e.address:][:4]
            values[e.params[k]] = int.from_bytes(data, "little", signed=True)
        if ids & set(values):
            out.append({i: v for i, v in values.items() if i in ids})
    return out


def test_a_joint_of_two_servos_is_written_in_one_sync_write_and_held_when_they_disagree(rig):
    since = time.monotonic()
    rig.publish("/joint_commands", JointState(name=["elbow"], position=[0.3]))
    goals_at(rig, {3: math.degrees(0.3), 4: -math.degrees(0.3)}, "elbow at 0.3 rad, servo 4 mounted the other way")
    writes = _goal_writes_of(rig, since, {3, 4})
    assert writes and all(set(w) == {3, 4} for w in writes), writes  # never one servo without the other
    rig.wait(lambda: at_rest(rig, 3) and at_rest(rig, 4), timeout=15, what="the elbow's servos at rest")
    mark = rig.mark()
    servo = rig.sim.servo(4)
    servo.pin("present_position", servo.read("present_position") + round(10.0 / servo.model.position_deg_per_pulse))
    try:
        rig.wait_log("joint elbow: servos [3, 4] disagree by", "held where each was", since=mark)
        rig.fresh_states(count=3)
        assert servo_deg(rig, 3) == pytest.approx(math.degrees(0.3), abs=0.2)  # held where it was
    finally:
        servo.pin("present_position", None)
    rig.publish("/joint_commands", JointState(name=["elbow"], position=[-0.3]))  # a later command is taken
    goals_at(rig, {3: -math.degrees(0.3), 4: math.degrees(0.3)}, "elbow at -0.3 rad")
    rig.wait_log("joint elbow: servos [3, 4] agree again", since=mark)  # once each is at its goal
    rig.wait(lambda: at_rest(rig, 3) and at_rest(rig, 4), timeout=15, what="the elbow's servos at rest")
    assert servo_deg(rig, 3, "present_position") == pytest.approx(-math.degrees(0.3), abs=1.0)
    assert servo_deg(rig, 4, "present_position") == pytest.approx(math.degrees(0.3), abs=1.0)


def test_a_coupled_set_is_written_in_one_sync_write_solved_from_its_joints(rig):
    since = time.monotonic()
    rig.publish("/joint_commands", JointState(name=["wrist_pitch", "wrist_roll"], position=[0.2, 0.1]))
    # pitch = (s5 + s6) / 2, roll = (s5 - s6) / 2: s5 = pitch + roll, s6 = pitch - roll
    goals_at(rig, {5: math.degrees(0.3), 6: math.degrees(0.1)}, "wrist at pitch 0.2, roll 0.1 rad")
    writes = _goal_writes_of(rig, since, {5, 6})
    assert writes and all(set(w) == {5, 6} for w in writes), writes
    rig.publish("/joint_commands", JointState(name=["wrist_roll"], position=[0.0]))  # pitch kept where it is
    goals_at(rig, {5: math.degrees(0.2), 6: math.degrees(0.2)}, "wrist roll 0, pitch kept")


def test_a_block_that_cannot_be_right_stops_the_node_with_one_line():
    node = NodeProcess(node_command("debug:=true", "joints.a.id:=1", "joints.b.id:=1"))
    assert node.wait_exit() == 2
    assert "joints.b.id = 1: servo 1 already drives joint 'a': one joint per servo" in node.output
    assert "Traceback" not in node.output


def test_diagnostics_has_a_status_per_joint_in_its_units(rig):
    from diagnostic_msgs.msg import DiagnosticArray
    got: list[DiagnosticArray] = []
    with rig._lock:
        rig.node.create_subscription(DiagnosticArray, "/diagnostics", got.append, 10)

    def joint_status(name: str):
        for msg in reversed(got):
            for s in msg.status:
                if s.name == f"dynamixel_handler: joint {name}":
                    return s
        return None
    rig.wait(lambda: joint_status("gripper") is not None and joint_status("elbow") is not None, timeout=15,
             what="/diagnostics with the joints' statuses")
    gripper = {kv.key: kv.value for kv in joint_status("gripper").values}
    assert gripper["servos"] == "ID 2" and "position [m]" in gripper and "velocity [m/s]" in gripper
    assert {kv.key: kv.value for kv in joint_status("elbow").values}["servos"] == "ID 3, ID 4"
    assert joint_status("finger") is None  # a mimic joint: state only
