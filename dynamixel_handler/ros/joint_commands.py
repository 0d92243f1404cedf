"""Joints commanded by name: ``joint_commands`` (sensor_msgs/JointState) and ``~/joint_trajectory``
(trajectory_msgs/JointTrajectory). The ``~/follow_joint_trajectory`` action
(control_msgs/FollowJointTrajectory, ``trajectory_action.py``) is attached to them by the node when
``control_msgs`` is installed (``missing_package``); this module never imports it.

``joint_commands`` is what ros2_control's ``joint_state_topic_hardware_interface`` publishes
(its ``joint_commands_topic``; states go to its ``joint_states_topic`` from ``joint_states``), so a
URDF naming that plugin puts ros2_control's controllers and MoveIt on the servos. Trajectories are
followed by the loop thread (``trajectory.Follower``, a step hook), interpolated at the loop rate.
Everything needs ``joint_state.use`` and a joint map; commands go through the Commander's checks.
"""
from __future__ import annotations

import importlib.util
import math
import time
from typing import Any, Callable

import numpy as np
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from ..commands.joint_goals import JointGoals
from ..commands.trajectory import MAX_POINTS, PREEMPTED, Follower, Job, Points, Tolerances, TrajectoryError, make_points
from ..joints import JointMap, LiveJoints
from .cdr import Codec, self_check
from .cdr_counts import sequence_counts

DEG = math.pi / 180.0
#: a trajectory whose header.stamp starts it further ahead than this is refused [s]
START_HORIZON_S = 60.0
#: a trajectory that starts at least this far ahead is announced with one line [s]
ANNOUNCE_START_S = 1.0
#: largest joint_commands message taken [bytes]: more is refused before it is decoded (a command
#: for 253 joints with 40-character names takes about 18 kB)
MAX_COMMAND_BYTES = 65_536
#: why a trajectory is refused: its joints, or the rest of it (FollowJointTrajectory's two codes)
BAD_JOINTS, BAD_GOAL = "joints", "goal"


class TrajectoryRefused(ValueError):
    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


def duration_s(d) -> float:
    return float(d.sec) + float(d.nanosec) * 1e-9


class JointCommands:
    """The topics, the follower hook and (optionally) the action of one node."""

    def __init__(self, node, joints: LiveJoints) -> None:
        self.node = node
        self.log = node.get_logger()
        self.joints = joints  # calibrated on the loop thread (``calibration``)
        self.goals = JointGoals(node.commander, joints)
        node.handler.attach(self.goals)
        traj = node.settings.trajectory
        self.default_path_rad = traj.path_tolerance_deg * DEG
        self.default_goal_rad = traj.goal_tolerance_deg * DEG
        self.default_goal_time = traj.goal_time_s
        self.follower = Follower(self.goals, 1.0 / float(node.settings.loop.rate_hz), node.adapter)
        self._subscribe_joint_commands()
        node.create_subscription(JointTrajectory, "~/joint_trajectory", self._on_trajectory, 10)
        self.action: Any = None  # trajectory_action.TrajectoryAction, when the node attaches it

    @property
    def mapping(self) -> JointMap:
        return self.joints.map

    def step(self, report: Any) -> None:
        """Loop hook: the joints of several servos watched on each read of the present positions,
        then the trajectory followed."""
        if "position" in report.present:
            self.goals.watch_pairs()
        self.follower(report)

    # ------------------------------------------------------------------ joint_commands
    def _subscribe_joint_commands(self) -> None:
        """joint_commands is taken like the command topics: by the loop thread at the start of a
        step (``intake.py``), as CDR bytes decoded straight into numpy where the codec agrees with
        the middleware on JointState, and screened for its size before it is decoded."""
        intake = self.node.intake
        raw = intake.raw and self_check([JointState]) is None
        intake.subscribe(JointState, "joint_commands", self._on_joint_commands, 10, raw=raw, screen=self._screen)
        self._codec = Codec.of(JointState)

    def _screen(self, msg: Any) -> bool:
        """False (and one line a second) for a message larger than any command of these joints:
        more bytes than ``MAX_COMMAND_BYTES``, or more names or values than there are joints. For
        bytes, from its length and the names' count prefix, before anything is decoded."""
        joints = len(self.mapping.names)
        if isinstance(msg, (bytes, bytearray, memoryview)):
            counts = sequence_counts(self._codec, msg)
            size = len(msg)
        else:
            counts = {f: len(getattr(msg, f)) for f in ("name", "position", "velocity", "effort")}
            size = len(msg.header.frame_id) + sum(len(n) + 8 for n in msg.name[:joints + 1]) + 8 * sum(counts.values())
        over = {f: n for f, n in counts.items() if n > joints}
        if over:
            field, n = next(iter(over.items()))
            why = f"{n} {field}{'s' if field == 'name' else ' values'}, more than the {joints} joints handled"
        elif size > MAX_COMMAND_BYTES:
            why = f"{size} bytes, more than the {MAX_COMMAND_BYTES} a command may have"
        else:
            return True
        self.goals.commander.throttle(f"joint_commands: refused: {why} (not decoded)",
                                     key=f"joint_commands size {next(iter(over), 'bytes')}")
        return False

    def _on_joint_commands(self, msg: dict[str, Any]) -> None:
        try:
            names = msg["name"]
            fields = (msg["position"], msg["velocity"], msg["effort"])
            problem = self.goals.check("joint_commands", names, *fields)
            if problem is not None:
                self.goals.commander.warn(problem)
                return
            active = self.follower.active  # a command for a joint of a running trajectory ends it first
            if active is not None and not set(active.names).isdisjoint(names):
                self.follower.stop(active, PREEMPTED, "preempted by joint_commands", hold=False)
            position, velocity, effort = (f.tolist() for f in fields)
            self.goals.command("joint_commands", names, position, velocity, effort, checked=True)
        except Exception as exc:  # a bad message must never take the node down
            self.log.error(f"joint_commands: dropped: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ trajectories
    def job(self, what: str, traj: JointTrajectory, path_tol=(), goal_tol=(), goal_time: float = 0.0) -> Job:
        """A checked job for the follower; TrajectoryRefused (kind and one line) otherwise."""
        if self.node.handler.refuse_ops:  # e.g. an inactive lifecycle node: the loop would never follow it
            raise TrajectoryRefused(BAD_GOAL, f"not now: {self.node.handler.refuse_ops}")
        gone = self.follower.device_gone()
        if gone:
            raise TrajectoryRefused(BAD_GOAL, f"{gone}: no trajectory until it is back")
        stop = self.node.handler.figures().e_stop
        if stop is not None:
            raise TrajectoryRefused(BAD_GOAL, f"the E-stop is engaged ({stop}): no trajectory until it is released")
        pts = traj.points
        if len(pts) > MAX_POINTS:  # before anything that grows with the points
            raise TrajectoryRefused(BAD_GOAL, f"{len(pts)} points, more than the {MAX_POINTS} a trajectory may have")
        names = list(traj.joint_names)
        self._check_joints(names)
        try:
            points = make_points(len(names), [duration_s(p.time_from_start) for p in pts],
                                 [p.positions for p in pts], [p.velocities for p in pts],
                                 [p.accelerations for p in pts])
        except TrajectoryError as err:
            raise TrajectoryRefused(BAD_GOAL, str(err)) from None
        self._check_bounds(names, points)
        path = self._tolerances("path_tolerance", names, path_tol, self.default_path_rad)
        goal = self._tolerances("goal_tolerance", names, goal_tol, self.default_goal_rad)
        start_wall = self._start_wall(what, duration_s(traj.header.stamp), points.duration)
        tol = Tolerances(path=path, goal=goal,
                         goal_time=goal_time if goal_time > 0 else self.default_goal_time)
        return Job(what, names, points, tol, start_wall)

    def _check_bounds(self, names: list[str], points: Points) -> None:
        """TrajectoryRefused naming the first point and joint outside the joint's soft limits
        (``joints.<name>.limits.position``) or its servo's position limits."""
        soft = np.array([self.mapping.joint(n).position_limits for n in names], dtype=np.float64).reshape(-1, 2)
        beyond = (points.positions < soft[:, 0]) | (points.positions > soft[:, 1])
        if beyond.any():
            k, j = (int(i) for i in np.argwhere(beyond)[0])
            raise TrajectoryRefused(BAD_GOAL, f"point {k}: joint {names[j]} at {points.positions[k, j]:.6g} is beyond "
                                              f"its limits [{soft[j, 0]:g}, {soft[j, 1]:g}] "
                                              f"(joints.{names[j]}.limits.position)")
        self._check_speeds(names, points)
        lo, hi = self.goals.position_bounds(names)
        outside = (points.positions < lo) | (points.positions > hi)
        if outside.any():
            k, j = (int(i) for i in np.argwhere(outside)[0])
            raise TrajectoryRefused(BAD_GOAL, f"point {k}: joint {names[j]} at {points.positions[k, j]:.6g} is "
                                              f"beyond its servo's position limits ({lo[j]:.4f} .. {hi[j]:.4f}, "
                                              f"ID {', '.join(map(str, self.mapping.joint(names[j]).servo_ids))})")

    def _check_speeds(self, names: list[str], points: Points) -> None:
        """TrajectoryRefused naming the first point and joint faster than the joint's velocity
        limit (``joints.<name>.limits.velocity``): a velocity given, or the mean speed from the
        point before."""
        limit = np.array([self.mapping.joint(n).velocity_limit for n in names], dtype=np.float64)
        if not np.isfinite(limit).any():
            return
        speed = np.abs(points.velocities)
        if len(points) > 1:
            dt = np.diff(points.times)[:, None]
            mean = np.abs(np.diff(points.positions, axis=0)) / np.where(dt > 0, dt, np.inf)
            speed = np.maximum(speed, np.vstack([np.zeros((1, len(names))), mean]))
        beyond = speed > limit * (1.0 + 1e-9)
        if beyond.any():
            k, j = (int(i) for i in np.argwhere(beyond)[0])
            raise TrajectoryRefused(BAD_GOAL, f"point {k}: joint {names[j]} at {speed[k, j]:.6g}/s is faster than its "
                                              f"limit {limit[j]:g}/s (joints.{names[j]}.limits.velocity)")

    def _check_joints(self, names: list[str]) -> None:
        """TrajectoryRefused unless the joints are known, named once and on handled servos."""
        if not names:
            raise TrajectoryRefused(BAD_JOINTS, "the trajectory names no joints")
        unknown = [n for n in names if n not in self.mapping.names]
        if unknown:
            raise TrajectoryRefused(BAD_JOINTS, f"unknown joints {[n[:40] for n in unknown[:5]]} "
                                                f"(this handler's joints: {', '.join(self.mapping.names)})")
        if len(set(names)) != len(names):
            raise TrajectoryRefused(BAD_JOINTS, f"a joint is named twice in {names[:10]}")
        table = self.node.handler.table
        unhandled = [n for n in names if any(i not in table for i in self.mapping.joint(n).servo_ids)]
        if unhandled:
            raise TrajectoryRefused(BAD_JOINTS, f"joints {unhandled} map to servos that are not handled")

    def _start_wall(self, what: str, stamp: float, duration: float) -> float:
        """When the trajectory starts (``time.time()``): now, or ``header.stamp`` on the node's
        clock (announced with one line when that is ``ANNOUNCE_START_S`` or more ahead);
        TrajectoryRefused when it has already ended or starts beyond ``START_HORIZON_S``."""
        now_wall = time.time()
        if stamp <= 0:
            return now_wall
        ahead = stamp - self.node.get_clock().now().nanoseconds * 1e-9
        start_wall = now_wall + ahead
        if start_wall + duration < now_wall:
            raise TrajectoryRefused(BAD_GOAL, f"the trajectory ended {now_wall - start_wall - duration:.2f} s "
                                              "ago (header.stamp + the last time_from_start is in the past)")
        if ahead > START_HORIZON_S:
            raise TrajectoryRefused(BAD_GOAL, f"header.stamp starts the trajectory in {ahead:.6g} s, beyond the "
                                              f"{START_HORIZON_S:g} s horizon")
        if ahead >= ANNOUNCE_START_S:
            self.log.info(f"{what}: starts in {ahead:.1f} s (header.stamp {stamp:.3f}), "
                          f"ends {ahead + duration:.1f} s from now")
        return start_wall

    def _tolerances(self, what: str, names: list[str], given, default: float):
        out = np.full(len(names), default)
        for tol in given:
            if tol.name not in names:
                raise TrajectoryRefused(BAD_GOAL, f"{what} names joint '{tol.name[:40]}', which is not in the trajectory")
            if not math.isfinite(tol.position):
                raise TrajectoryRefused(BAD_GOAL, f"{what} of {tol.name}: position {tol.position} is not a number")
            if tol.position > 0:
                out[names.index(tol.name)] = tol.position
            elif tol.position < 0:  # -1: erased, not checked
                out[names.index(tol.name)] = 0.0
        return out

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        try:
            if not msg.points:  # as joint_trajectory_controller: an empty trajectory stops where the joints are
                active = self.follower.active
                if active is not None:
                    self.follower.stop(active, "cancelled", "stopped by an empty trajectory")
                else:
                    self.goals.hold("joint_trajectory (empty: hold)", [n for n in msg.joint_names if n in self.mapping.names])
                return
            self.follower.start(self.job("joint_trajectory", msg))
        except TrajectoryRefused as err:
            self.goals.commander.warn(f"joint_trajectory: refused: {err}")
        except Exception as exc:  # a bad message must never take the node down
            self.log.error(f"joint_trajectory: dropped: {type(exc).__name__}: {exc}")


def missing_package(name: str = "control_msgs") -> str | None:
    """Why the package ``name`` cannot serve the action (it is not installed), or None when it is
    there. Only the package is looked for: an error in our own action module is not hidden."""
    return None if importlib.util.find_spec(name) is not None else f"No module named '{name}'"


def attach(node) -> Callable[[Any], None] | None:
    """The follower hook when ``joint_state.use`` is on (the mapping is checked at parameter load)."""
    if not node.settings.ros.joint_state_use or node.joints is None:  # never None with it (ConfigError instead)
        return None
    node.joint_commands = JointCommands(node, node.joints)
    return node.joint_commands.step
