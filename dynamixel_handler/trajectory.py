"""Joint trajectories: interpolation between points and the rules of following one. ROS-free.

A trajectory is a list of points (time from its start, positions, optional velocities and
accelerations) for a set of joints. Between two points each joint follows

- a straight line when the points give positions only,
- a cubic polynomial when they give positions and velocities,
- a quintic polynomial when they also give accelerations,

so positions, and velocities and accelerations where given, are met exactly at the points (the
same rules as ros2_control's joint_trajectory_controller). Before the first point the joints move
from where they were when the trajectory started; after the last they stay there.

:class:`TrajectoryRun` judges one run from samples of the present positions: the path tolerance
while the trajectory runs, the goal tolerance once it has ended, and the time allowed after the
end (goal time tolerance). Angles are joint angles in radians, times in seconds.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

#: outcomes of a run (the FollowJointTrajectory result codes where one exists)
RUNNING, SUCCEEDED, PATH_VIOLATED, GOAL_VIOLATED = "running", "succeeded", "path_violated", "goal_violated"
#: how a run ends besides those: replaced by a newer one, cancelled, or unable to go on
PREEMPTED, CANCELLED, ABORTED = "preempted", "cancelled", "aborted"


class TrajectoryError(ValueError):
    """A trajectory that cannot be followed; the message says why, for the caller."""


@dataclass(frozen=True)
class Point:
    t: float
    positions: np.ndarray
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None


@dataclass(frozen=True)
class Sample:
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


def make_points(n_joints: int, times: Sequence[float], positions: Sequence[Sequence[float]],
                velocities: Sequence[Sequence[float]], accelerations: Sequence[Sequence[float]]) -> list[Point]:
    """Checked points: every point gives n positions (and n velocities / accelerations or none),
    times strictly increase, every number is finite. TrajectoryError naming the point otherwise."""
    if not len(times):
        raise TrajectoryError("the trajectory has no points")
    points: list[Point] = []
    last_t = -math.inf
    for k, t in enumerate(times):
        last_t = _point_time(k, t, last_t)
        p = _joint_values(k, "positions", positions[k], n_joints)
        v = _optional_joint_values(k, "velocities", velocities[k], n_joints)
        a = _optional_joint_values(k, "accelerations", accelerations[k], n_joints)
        if a is not None and v is None:
            raise TrajectoryError(f"point {k}: accelerations without velocities")
        points.append(Point(last_t, p, v, a))
    return points


def _point_time(k: int, t: float, last_t: float) -> float:
    """Time of point ``k`` as a float: a time >= 0 after ``last_t`` (the time of point k - 1)."""
    t = float(t)
    if not math.isfinite(t) or t < 0:
        raise TrajectoryError(f"point {k}: time_from_start {t} is not a time >= 0")
    if t <= last_t:
        raise TrajectoryError(f"point {k}: time_from_start {t:g} s does not come after point {k - 1} ({last_t:g} s)")
    return t


def _joint_values(k: int, what: str, given: Sequence[float], n_joints: int) -> np.ndarray:
    """One finite value per joint of point ``k`` (``what``: positions, velocities, accelerations)."""
    if len(given) != n_joints:
        raise TrajectoryError(f"point {k}: {len(given)} {what} for {n_joints} joints")
    a = np.asarray(given, dtype=np.float64)
    if not np.isfinite(a).all():
        raise TrajectoryError(f"point {k}: {what} are not all finite numbers")
    return a


def _optional_joint_values(k: int, what: str, given: Sequence[float], n_joints: int) -> np.ndarray | None:
    """As :func:`_joint_values`; None when the point does not give them."""
    return None if len(given) == 0 else _joint_values(k, what, given, n_joints)


def _coefficients(p0, v0, a0, p1, v1, a1, h: float) -> np.ndarray:
    """Polynomial coefficients (rows: power 0..5, columns: joints) of one segment of length h."""
    n = len(p0)
    c = np.zeros((6, n))
    c[0] = p0
    if v0 is None or v1 is None:  # positions only: a straight line
        c[1] = (p1 - p0) / h
        return c
    c[1] = v0
    if a0 is None or a1 is None:  # cubic
        c[2] = (3 * (p1 - p0) - (2 * v0 + v1) * h) / h ** 2
        c[3] = (2 * (p0 - p1) + (v0 + v1) * h) / h ** 3
        return c
    c[2] = a0 / 2
    c[3] = (20 * (p1 - p0) - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h ** 2) / (2 * h ** 3)
    c[4] = (30 * (p0 - p1) + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h ** 2) / (2 * h ** 4)
    c[5] = (12 * (p1 - p0) - 6 * (v1 + v0) * h + (a1 - a0) * h ** 2) / (2 * h ** 5)
    return c


class Trajectory:
    """Points joined by polynomial segments, starting from the joints' state at time 0."""

    def __init__(self, points: list[Point], start: np.ndarray, start_velocity: np.ndarray | None = None) -> None:
        if points[0].t > 0:  # from where the joints are to the first point
            first = Point(0.0, np.asarray(start, dtype=np.float64),
                          None if points[0].velocities is None else
                          (np.zeros(len(start)) if start_velocity is None else np.asarray(start_velocity, dtype=np.float64)),
                          None if points[0].accelerations is None else np.zeros(len(start)))
            points = [first] + list(points)
        self.points = points
        self.times = np.array([p.t for p in points])
        self.duration = float(self.times[-1])
        self._coef = [_coefficients(a.positions, a.velocities, a.accelerations,
                                    b.positions, b.velocities, b.accelerations, b.t - a.t)
                      for a, b in zip(points, points[1:])]

    def sample(self, t: float) -> Sample:
        """Positions, velocities and accelerations at ``t`` seconds after the start."""
        last = self.points[-1]
        n = len(last.positions)
        if t >= self.duration or not self._coef:
            return Sample(last.positions.copy(), np.zeros(n) if last.velocities is None else last.velocities.copy(),
                          np.zeros(n) if last.accelerations is None else last.accelerations.copy())
        t = max(t, 0.0)
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        c, s = self._coef[k], t - self.times[k]
        powers = s ** np.arange(6)
        d1 = np.array([0, 1, 2 * s, 3 * s ** 2, 4 * s ** 3, 5 * s ** 4])
        d2 = np.array([0, 0, 2, 6 * s, 12 * s ** 2, 20 * s ** 3])
        return Sample(powers @ c, d1 @ c, d2 @ c)


@dataclass
class Tolerances:
    """Per joint, radians; 0 or less: not checked. ``goal_time``: seconds allowed after the end."""

    path: np.ndarray
    goal: np.ndarray
    goal_time: float


@dataclass
class Verdict:
    outcome: str
    message: str = ""
    desired: Sample | None = None
    error: np.ndarray = field(default_factory=lambda: np.zeros(0))


class TrajectoryRun:
    """One trajectory being followed: what to command at a time, and whether it went well."""

    def __init__(self, names: Sequence[str], trajectory: Trajectory, tolerances: Tolerances) -> None:
        self.names = list(names)
        self.trajectory = trajectory
        self.tol = tolerances
        self.max_error = np.zeros(len(self.names))  # largest |present - desired| seen while running

    def judge(self, t: float, present: np.ndarray) -> Verdict:
        """The verdict at ``t`` s after the start, from the present positions read then (NaN: not read)."""
        desired = self.trajectory.sample(t)
        error = np.asarray(present, dtype=np.float64) - desired.positions
        known = np.isfinite(error)
        abs_err = np.where(known, np.abs(error), 0.0)
        self.max_error = np.maximum(self.max_error, abs_err)
        if t < self.trajectory.duration:
            over = known & (self.tol.path > 0) & (abs_err > self.tol.path)
            if over.any():
                k = int(np.argmax(over))
                return Verdict(PATH_VIOLATED, f"joint {self.names[k]} is {abs_err[k]:.4f} rad off the path "
                               f"at {t:.2f} s (path tolerance {self.tol.path[k]:g} rad)", desired, error)
            return Verdict(RUNNING, "", desired, error)
        goal = self.trajectory.points[-1].positions
        end_err = np.asarray(present, dtype=np.float64) - goal
        checked = self.tol.goal > 0
        bad = checked & ~(np.abs(end_err) <= self.tol.goal)  # NaN (not read) counts as not there
        if not bad.any():
            return Verdict(SUCCEEDED, "", desired, error)
        if t > self.trajectory.duration + self.tol.goal_time:
            far = ", ".join(f"{self.names[k]} {abs(end_err[k]):.4f} rad away (tolerance {self.tol.goal[k]:g})"
                            for k in np.flatnonzero(bad))
            return Verdict(GOAL_VIOLATED, f"{self.tol.goal_time:g} s after the end: {far}", desired, error)
        return Verdict(RUNNING, "", desired, error)


@dataclass
class Job:
    """One trajectory handed to the follower: by the action (which waits on ``done``) or the topic."""

    what: str
    names: list[str]
    points: list[Point]
    tolerances: Tolerances
    start_wall: float                       # time.time() of time_from_start = 0
    run: TrajectoryRun | None = None
    outcome: str = RUNNING
    message: str = ""
    last: tuple | None = None               # (t, Verdict, present positions, present velocities) of the last read
    done: threading.Event = field(default_factory=threading.Event)


class Follower:
    """Loop hook: commands the active trajectory's positions every loop (one period ahead, as they
    are written with the next loop) and judges it on every read of the present positions. ``goals``
    is a :class:`~dynamixel_handler.joint_goals.JointGoals`; a new job replaces (preempts) the old."""

    def __init__(self, goals, period_s: float, log) -> None:
        self.goals = goals
        self.period_s = period_s
        self.log = log
        self._lock = threading.Lock()
        self.active: Job | None = None

    def start(self, job: Job) -> Job | None:
        """Make ``job`` the one followed; the job it replaces (ended as preempted), if any."""
        with self._lock:
            old, self.active = self.active, job
        if old is not None:
            self._end(old, PREEMPTED, "preempted by a newer trajectory", hold=False)
        return old

    def stop(self, job: Job, outcome: str, message: str, hold: bool = True) -> None:
        """End ``job`` (cancel, node stopping: the joints hold where they are; a joint command: not)."""
        with self._lock:
            if self.active is not job:
                return
            self.active = None
        self._end(job, outcome, message, hold=hold)

    def _end(self, job: Job, outcome: str, message: str, hold: bool) -> None:
        job.outcome, job.message = outcome, message
        if hold:
            self.goals.hold(f"{job.what} ({outcome})", job.names)
        job.done.set()

    def __call__(self, report) -> None:
        job = self.active
        if job is None:
            return
        now = time.time()
        if "position" in report.present and not self._judge(job, report.stamp):
            return
        self._command_ahead(job, now)

    def _judge(self, job: Job, stamp: float) -> bool:
        """Judge ``job`` on the positions just read (its run starts from the first read); False
        when that ended the job."""
        present, velocity = self.goals.present(job.names)
        run = job.run if job.run is not None else self._start_run(job, present, velocity)
        if run is None:
            return False
        t = stamp - job.start_wall
        if t >= 0:
            verdict = run.judge(t, np.array(present))
            job.last = (t, verdict, present, velocity)
            if verdict.outcome != RUNNING:
                self._finish(job, verdict.outcome, verdict.message, hold=verdict.outcome != SUCCEEDED)
                return False
        return True

    def _start_run(self, job: Job, present: list[float], velocity: list[float]) -> TrajectoryRun | None:
        """The run of ``job`` from the present positions and velocities; None (and the job aborted)
        when a joint's position is not known."""
        if not all(math.isfinite(p) for p in present):
            missing = [n for n, p in zip(job.names, present) if not math.isfinite(p)]
            self._finish(job, ABORTED, f"no present position of {missing} to start from", hold=False)
            return None
        job.run = TrajectoryRun(job.names, Trajectory(job.points, np.array(present), np.array(velocity)),
                                job.tolerances)
        return job.run

    def _command_ahead(self, job: Job, now: float) -> None:
        """Command the positions of one period ahead, once the job has a run and has begun by then."""
        if job.run is not None and now + self.period_s >= job.start_wall:
            target = job.run.trajectory.sample(now + self.period_s - job.start_wall)
            with self._lock:  # a job stopped meanwhile queues nothing after what stopped it
                if self.active is job:
                    self.goals.command(job.what, job.names, position=target.positions.tolist())

    def _finish(self, job: Job, outcome: str, message: str, hold: bool) -> None:
        with self._lock:
            if self.active is not job:
                return
            self.active = None
        if outcome not in (SUCCEEDED,):
            self.log.warning(f"{job.what}: {message}")
        self._end(job, outcome, message, hold)
