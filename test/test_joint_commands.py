"""Joints by name: joint_commands (ros2_control's topic-based hardware interface), the
joint_trajectory topic and the follow_joint_trajectory action, through the real node on the
virtual bus. Positions are read back from the simulated servos' registers."""
from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from dynamixel_handler.commands.trajectory import Trajectory, make_points
from dynamixel_handler_msgs.msg import DynamixelStatus

from support.rig import SYNC_WRITE, X540, Rig, X

R = FollowJointTrajectory.Result
JOINTS = ("joint_state.use:=true", "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]",
          "joint_state.directions:=[1, -1]", "joint_state.offsets_deg:=[0.0, 10.0]")
ACTION = "/dynamixel_handler/follow_joint_trajectory"


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540}, *JOINTS, "loop_rate:=100", "baudrate:=1000000",
            sim_kwargs={"baudrate": 1_000_000})
    yield r
    assert r.close() == 0


def servo_deg(rig: Rig, dxl_id: int, item: str = "present_position") -> float:
    servo = rig.sim.servo(dxl_id)
    return (servo.read(item) - servo.model.position_zero_pulse) * servo.model.position_deg_per_pulse


def joint_rad(rig: Rig, name: str, item: str = "present_position") -> float:
    """The joint angle a simulated servo's register says (pan: ID 1 as is; tilt: ID 2 flipped, zero at 10 deg)."""
    if name == "pan":
        return math.radians(servo_deg(rig, 1, item))
    return -math.radians(servo_deg(rig, 2, item) - 10.0)


def point(t: float, positions, velocities=(), accelerations=()) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(positions=list(positions), velocities=list(velocities),
                                accelerations=list(accelerations),
                                time_from_start=Duration(sec=int(t), nanosec=int(round((t % 1) * 1e9))))


def client(rig: Rig) -> ActionClient:
    if not hasattr(rig, "fjt"):
        with rig._lock:
            rig.fjt = ActionClient(rig.node, FollowJointTrajectory, ACTION)
        assert rig.fjt.wait_for_server(timeout_sec=10)
    return rig.fjt


def written_goals(rig: Rig, since: float) -> list[tuple[float, float, float]]:
    """(wall-clock time, pan, tilt) [rad] of each Goal Position the node wrote with a Sync Write after
    ``since`` (monotonic), as the simulated bus received it (the joint not written keeps its last goal)."""
    servos = {i: rig.sim.servo(i) for i in (1, 2)}
    address = servos[1].model.item("goal_position").address
    to_wall = time.time() - time.monotonic()
    goals = {"pan": joint_rad(rig, "pan", "goal_position"), "tilt": joint_rad(rig, "tilt", "goal_position")}
    out = []
    for e in rig.sim.log:
        if e.time < since or e.instruction != SYNC_WRITE or not e.address <= address < e.address + e.length:
            continue
        for k in range(4, len(e.params), 1 + e.length):  # address, length, then ID + data per servo
            dxl_id, data = e.params[k], e.params[k + 1 + address - e.address:][:4]
            if dxl_id in servos:
                model = servos[dxl_id].model
                deg = (int.from_bytes(data, "little", signed=True) - model.position_zero_pulse) * model.position_deg_per_pulse
                goals["pan" if dxl_id == 1 else "tilt"] = math.radians(deg) if dxl_id == 1 else -math.radians(deg - 10.0)
        out.append((e.time + to_wall, goals["pan"], goals["tilt"]))
    return out


def send(rig: Rig, goal: FollowJointTrajectory.Goal, feedback: list | None = None):
    fut = rig.locked(client(rig).send_goal_async, goal,
                     feedback_callback=(lambda m: feedback.append(m.feedback)) if feedback is not None else None)
    rig.wait(fut.done, what="the goal accepted")
    handle = fut.result()
    assert handle.accepted
    return handle


def result_of(rig: Rig, handle, timeout: float = 20.0):
    fut = rig.locked(handle.get_result_async)
    rig.wait(fut.done, timeout=timeout, what="the goal's result")
    return fut.result().status, fut.result().result


def position_mode(rig: Rig, *ids: int) -> None:
    """The servos in position mode (Operating Mode 3), whatever an earlier test left them in."""
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=list(ids), mode=["position"] * len(ids)))
    rig.wait(lambda: all(rig.sim.servo(i).read("operating_mode") == 3 for i in ids), timeout=15, what="position mode")


def settle(rig: Rig, positions: dict[str, float]) -> None:
    """Put the joints at ``positions`` [rad] with joint_commands and wait until they are there."""
    rig.publish("/joint_commands", JointState(name=list(positions), position=list(positions.values())))
    rig.wait(lambda: all(abs(joint_rad(rig, n) - p) < 0.01 for n, p in positions.items()), timeout=15,
             what=f"joints at {positions}")


def test_joint_commands_by_name_move_the_servos_to_the_commanded_radians(rig):
    rig.publish("/joint_commands", JointState(name=["tilt", "pan"], position=[0.3, -0.5]))
    rig.wait(lambda: abs(joint_rad(rig, "tilt", "goal_position") - 0.3) < 0.002
             and abs(joint_rad(rig, "pan", "goal_position") + 0.5) < 0.002, what="goal registers set")
    # tilt: servo angle = -1 x 0.3 rad + 10 deg
    assert servo_deg(rig, 2, "goal_position") == pytest.approx(10.0 - math.degrees(0.3), abs=0.1)
    rig.wait(lambda: abs(joint_rad(rig, "pan") + 0.5) < 0.01 and abs(joint_rad(rig, "tilt") - 0.3) < 0.01,
             what="the servos at the commanded radians")
    assert rig.sim.servo(1).read("operating_mode") == 3  # position only: position control


def test_joint_command_velocity_only_switches_to_velocity_mode(rig):
    try:
        rig.publish("/joint_commands", JointState(name=["pan"], velocity=[0.5]))
        rig.wait(lambda: rig.sim.servo(1).read("operating_mode") == 1, timeout=15, what="velocity mode")
        servo = rig.sim.servo(1)
        rig.wait(lambda: servo.read("goal_velocity") * servo.model.velocity_deg_s_per_pulse
                 == pytest.approx(math.degrees(0.5), abs=0.3), what="goal velocity 0.5 rad/s")
    finally:
        rig.publish("/joint_commands", JointState(name=["pan"], velocity=[0.0]))
    # back to position: the next position command changes the mode again (after mode_change_interval_sec)
    rig.publish("/joint_commands", JointState(name=["pan"], position=[0.0]))
    rig.wait(lambda: rig.sim.servo(1).read("operating_mode") == 3, timeout=15, what="position mode again")


def test_unknown_names_and_bad_lengths_are_refused_with_one_line(rig):
    rig.fresh_states(count=3)  # the goal the previous test sent last has reached the servos
    before = {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)}
    mark = rig.mark()
    rig.publish("/joint_commands", JointState(name=["pan", "elbow"], position=[1.0, 1.0]))
    line = rig.wait_log("unknown joint names 'elbow'", since=mark)
    assert "refused" in line
    rig.publish("/joint_commands", JointState(name=["pan", "tilt"], position=[1.0]))
    rig.wait_log("1 position values for 2 joint names: refused", since=mark)
    rig.publish("/joint_commands", JointState(name=["pan"], position=[float("nan")]))
    rig.wait_log("'position_deg' = nan refused", since=mark)
    rig.fresh_states(count=5)
    assert {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)} == before
    assert rig.node_proc.proc.poll() is None


def test_a_three_point_trajectory_is_followed_with_the_timing_of_time_from_start(rig):
    settle(rig, {"pan": 0.0, "tilt": 0.0})
    feedback: list = []
    start_in = 0.5  # header.stamp in the future: the test knows the path's time axis exactly
    stamp = time.time() + start_in
    traj = JointTrajectory(joint_names=["pan", "tilt"],
                           points=[point(0.5, [0.4, -0.2], [0.6, -0.3]), point(1.0, [0.8, 0.1], [0.2, 0.3]),
                                   point(1.5, [0.6, 0.3], [0.0, 0.0])])
    traj.header.stamp.sec, traj.header.stamp.nanosec = int(stamp), int((stamp % 1) * 1e9)
    samples: list[tuple[float, float, float]] = []
    stop = threading.Event()

    def sample() -> None:  # the simulated servos' registers against the wall clock
        while not stop.is_set():
            samples.append((time.time(), joint_rad(rig, "pan"), joint_rad(rig, "tilt")))
            time.sleep(0.005)
    sampler = threading.Thread(target=sample, daemon=True)
    since = time.monotonic()
    origin = np.array([joint_rad(rig, "pan"), joint_rad(rig, "tilt")])  # where the path starts (settle: within 0.01)
    sampler.start()
    try:
        handle = send(rig, FollowJointTrajectory.Goal(trajectory=traj), feedback)
        status, result = result_of(rig, handle)
    finally:
        stop.set()
        sampler.join()
    assert result.error_code == R.SUCCESSFUL, result.error_string
    assert status == 4  # SUCCEEDED
    assert feedback and list(feedback[-1].joint_names) == ["pan", "tilt"]
    # the interpolated path (cubic: positions and velocities given), from where the joints were
    pts = make_points(2, [0.5, 1.0, 1.5], [[0.4, -0.2], [0.8, 0.1], [0.6, 0.3]],
                      [[0.6, -0.3], [0.2, 0.3], [0.0, 0.0]], [[], [], []])
    path = Trajectory(pts, origin)
    # the goals the node wrote, against the path at the moment the bus got them: the timing is the
    # node's own (a loop held back on a busy machine writes the path's point of when it runs, so the
    # servo lags then, not the goal; the registers sampled below would count that lag as an error)
    during = [(t - stamp, p, q) for t, p, q in written_goals(rig, since) if 0.0 <= t - stamp <= 1.5]
    assert len(during) > 50
    # each goal is a point of the path (its nearest point on a 1 ms grid), the points come in the
    # path's order, and at about the time the path gives them: judged on the path's shape and order,
    # with the timing loose enough for a host whose load holds a loop back (timing is for bench/)
    grid = np.arange(0.0, 1.5005, 0.001)
    curve = np.array([path.sample(float(t)).positions[:2] for t in grid])
    nearest = [int(np.argmin(np.max(np.abs(curve - [p, q]), axis=1))) for _, p, q in during]
    off_path = [float(np.max(np.abs(curve[k] - [p, q]))) for k, (_, p, q) in zip(nearest, during)]
    lags = [t - grid[k] for k, (t, _, _) in zip(nearest, during)]
    print(f"\ntrajectory tracking: {len(during)} goals written, off the path at most {max(off_path):.4f} rad, "
          f"written {1000 * float(np.median(lags)):.1f} ms after the path's time (median)")
    assert max(off_path) < 0.02, max(off_path)                       # on the path
    assert all(b >= a - 20 for a, b in zip(nearest, nearest[1:]))     # in its order (20 ms of slack)
    assert abs(float(np.median(lags))) < 0.1                          # a path 0.2 s late fails
    # the servos went the path's way: through its middle point (0.8, 0.1) on the way to the end
    assert any(abs(p - 0.8) < 0.05 and abs(q - 0.1) < 0.05 for _, p, q in samples)
    # nothing moved before header.stamp
    before = [(p, q) for t, p, q in samples if t - stamp < -0.05]
    assert before and all(abs(p) < 0.01 and abs(q) < 0.01 for p, q in before)
    assert joint_rad(rig, "pan") == pytest.approx(0.6, abs=0.02)
    assert joint_rad(rig, "tilt") == pytest.approx(0.3, abs=0.02)


def test_invalid_goals_are_refused_with_the_codes_and_a_reason(rig):
    def outcome(traj: JointTrajectory):
        return result_of(rig, send(rig, FollowJointTrajectory.Goal(trajectory=traj)))

    status, result = outcome(JointTrajectory(joint_names=["pan", "elbow"], points=[point(1.0, [0.0, 0.0])]))
    assert status == 6 and result.error_code == R.INVALID_JOINTS  # ABORTED
    assert "elbow" in result.error_string
    status, result = outcome(JointTrajectory(joint_names=["pan"], points=[point(1.0, [0.1]), point(0.5, [0.2])]))
    assert result.error_code == R.INVALID_GOAL and "does not come after" in result.error_string
    status, result = outcome(JointTrajectory(joint_names=["pan", "tilt"], points=[point(1.0, [0.1])]))
    assert result.error_code == R.INVALID_GOAL and "1 positions for 2 joints" in result.error_string


def test_preemption_and_cancel(rig):
    settle(rig, {"pan": 0.0})
    slow = JointTrajectory(joint_names=["pan"], points=[point(4.0, [1.5])])
    first = send(rig, FollowJointTrajectory.Goal(trajectory=slow))
    rig.wait(lambda: joint_rad(rig, "pan") > 0.1, what="the first goal under way")
    second = send(rig, FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=["pan"],
                                                                              points=[point(4.0, [-1.0])])))
    status, result = result_of(rig, first)
    assert status == 6 and result.error_code == R.SUCCESSFUL and "preempted" in result.error_string
    rig.wait(lambda: joint_rad(rig, "pan") < 0.0, what="the second goal moving the other way")
    rig.locked(second.cancel_goal_async)
    status, result = result_of(rig, second)
    assert status == 5  # CANCELED
    held = joint_rad(rig, "pan")
    time.sleep(0.5)
    assert joint_rad(rig, "pan") == pytest.approx(held, abs=0.02)  # holds where it was
    assert held > -0.9


def test_a_joint_command_ends_a_running_trajectory_of_that_joint(rig):
    settle(rig, {"pan": 0.0})
    handle = send(rig, FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=["pan"],
                                                                              points=[point(4.0, [1.5])])))
    rig.wait(lambda: joint_rad(rig, "pan") > 0.1, what="the goal under way")
    rig.publish("/joint_commands", JointState(name=["pan"], position=[-0.3]))
    status, result = result_of(rig, handle)
    assert status == 6 and "preempted by joint_commands" in result.error_string
    rig.wait(lambda: abs(joint_rad(rig, "pan") + 0.3) < 0.01, what="pan at the joint command's position")


def test_path_tolerance_violation_when_a_joint_is_held_back(rig):
    settle(rig, {"pan": 0.0, "tilt": 0.0})
    servo = rig.sim.servo(2)
    servo.pin("present_position", servo.read("present_position"))  # tilt cannot move
    try:
        goal = FollowJointTrajectory.Goal(
            trajectory=JointTrajectory(joint_names=["pan", "tilt"], points=[point(1.0, [0.5, 0.5])]),
            path_tolerance=[JointTolerance(name="tilt", position=0.1)])
        status, result = result_of(rig, send(rig, goal))
    finally:
        servo.pin("present_position", None)
    assert status == 6 and result.error_code == R.PATH_TOLERANCE_VIOLATED
    assert "tilt" in result.error_string and "path tolerance 0.1" in result.error_string


def test_goal_time_violation(rig):
    settle(rig, {"pan": 0.0, "tilt": 0.0})
    servo = rig.sim.servo(1)
    servo.pin("present_position", servo.read("present_position"))  # pan stays short of the goal
    try:
        goal = FollowJointTrajectory.Goal(
            trajectory=JointTrajectory(joint_names=["pan"], points=[point(0.5, [0.3])]),
            goal_tolerance=[JointTolerance(name="pan", position=0.02)], goal_time_tolerance=Duration(nanosec=300_000_000))
        status, result = result_of(rig, send(rig, goal))
    finally:
        servo.pin("present_position", None)
    assert status == 6 and result.error_code == R.GOAL_TOLERANCE_VIOLATED
    assert "pan" in result.error_string


def test_joint_trajectory_topic(rig):
    settle(rig, {"pan": 0.0, "tilt": 0.0})
    rig.publish("/dynamixel_handler/joint_trajectory",
                JointTrajectory(joint_names=["tilt"], points=[point(0.3, [0.2]), point(0.6, [-0.4])]))
    rig.wait(lambda: abs(joint_rad(rig, "tilt") + 0.4) < 0.01, what="tilt at the trajectory's end")
    mark = rig.mark()
    rig.publish("/dynamixel_handler/joint_trajectory", JointTrajectory(joint_names=["knee"], points=[point(0.3, [0.2])]))
    rig.wait_log("joint_trajectory: refused: unknown joints ['knee']", since=mark)



# ---------------------------------------------------------------------- bad goals refused at once
#: the documented most points of a goal (docs/robot_integration.md), and how far ahead it may start
MAX_POINTS, START_HORIZON_S = 1_000, 60.0


def test_a_goal_with_more_points_than_the_maximum_is_refused_at_once(rig):
    many = JointTrajectory(joint_names=["pan"],
                           points=[point(0.01 * (k + 1), [0.0]) for k in range(MAX_POINTS + 1)])
    t = time.monotonic()
    status, result = result_of(rig, send(rig, FollowJointTrajectory.Goal(trajectory=many)))
    assert status == 6 and result.error_code == R.INVALID_GOAL, result.error_string
    assert f"{MAX_POINTS + 1} points" in result.error_string and f"{MAX_POINTS}" in result.error_string
    assert time.monotonic() - t < 8.0  # at once, not after the 10 s it would take
    assert rig.node_proc.proc.poll() is None


def test_a_point_beyond_the_position_limits_is_refused_naming_joint_and_point(rig):
    position_mode(rig, 1, 2)  # the limits of position mode (another test may leave tilt in cur_position)
    settle(rig, {"pan": 0.0, "tilt": 0.0})
    before = {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)}
    # pan (position mode, limits 0..4095 pulses: -pi..pi rad) at 1e308 rad in point 1
    status, result = result_of(rig, send(rig, FollowJointTrajectory.Goal(trajectory=JointTrajectory(
        joint_names=["tilt", "pan"], points=[point(0.5, [0.1, 0.2]), point(1.0, [0.1, 1e308])]))))
    assert status == 6 and result.error_code == R.INVALID_GOAL, result.error_string
    assert "point 1" in result.error_string and "pan" in result.error_string and "limit" in result.error_string
    # just beyond: tilt (direction -1, offset 10 deg) at -3.2 rad is servo 10 + 183 deg, past 180
    status, result = result_of(rig, send(rig, FollowJointTrajectory.Goal(trajectory=JointTrajectory(
        joint_names=["tilt"], points=[point(0.5, [0.0]), point(0.8, [0.5]), point(1.0, [-3.2])]))))
    assert result.error_code == R.INVALID_GOAL and "point 2" in result.error_string and "tilt" in result.error_string
    rig.fresh_states(count=3)
    assert {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)} == before  # nothing moved


def test_a_start_beyond_the_horizon_is_refused_and_a_later_start_is_announced(rig):
    def stamped(ahead_s: float) -> JointTrajectory:
        traj = JointTrajectory(joint_names=["pan"], points=[point(0.5, [0.0])])
        stamp = time.time() + ahead_s
        traj.header.stamp.sec, traj.header.stamp.nanosec = int(stamp), int((stamp % 1) * 1e9)
        return traj
    six_years = 6 * 365 * 86400.0
    status, result = result_of(rig, send(rig, FollowJointTrajectory.Goal(trajectory=stamped(six_years))))
    assert status == 6 and result.error_code == R.INVALID_GOAL
    assert "horizon" in result.error_string and f"{START_HORIZON_S:g} s" in result.error_string
    mark = rig.mark()
    handle = send(rig, FollowJointTrajectory.Goal(trajectory=stamped(30.0)))
    line = rig.wait_log("follow_joint_trajectory: starts in", since=mark)
    assert "header.stamp" in line
    rig.locked(handle.cancel_goal_async)
    status, _ = result_of(rig, handle)
    assert status == 5  # CANCELED


# ---------------------------------------------------------------------- joint_commands: size
def test_an_oversized_joint_commands_message_is_refused_with_one_line(rig):
    rig.fresh_states(count=3)
    before = {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)}
    mark = rig.mark()
    many = 100_000
    rig.publish("/joint_commands", JointState(name=["pan"] * many, position=[0.5] * many))
    line = rig.wait_log("joint_commands: refused", f"{many} names", since=mark)
    assert "more than the 2 joints" in line
    big = JointState(name=["pan"], position=[0.5])
    big.header.frame_id = "f" * 2_000_000
    rig.publish("/joint_commands", big)
    line = rig.wait_log("joint_commands: refused", "bytes", since=mark)
    assert "more than" in line
    rig.fresh_states(count=5)
    assert {i: rig.sim.servo(i).read("goal_position") for i in (1, 2)} == before
    # and the next valid command is taken
    rig.publish("/joint_commands", JointState(name=["pan"], position=[0.2]))
    rig.wait(lambda: abs(joint_rad(rig, "pan", "goal_position") - 0.2) < 0.002, what="pan commanded after them")
    assert len(rig.log_since(mark).splitlines()) < 10


def test_position_with_effort_is_current_based_position_with_that_current_limit(rig):
    # last in this file: tilt stays in current-based position mode
    rig.publish("/joint_commands", JointState(name=["tilt"], position=[0.1], effort=[0.5]))
    servo = rig.sim.servo(2)
    rig.wait(lambda: servo.read("operating_mode") == 5, timeout=15, what="current-based position mode")
    rig.wait(lambda: abs(servo.read("goal_current") * servo.model.current_ma_per_pulse - 500.0) < 5.0,
             what="goal current 0.5 A")
    rig.wait(lambda: abs(joint_rad(rig, "tilt") - 0.1) < 0.01, what="tilt at 0.1 rad")
    # a position alone now keeps the mode (as for a servo set up in it)
    rig.publish("/joint_commands", JointState(name=["tilt"], position=[-0.1]))
    rig.wait(lambda: abs(joint_rad(rig, "tilt") + 0.1) < 0.01, what="tilt at -0.1 rad")
    assert servo.read("operating_mode") == 5
