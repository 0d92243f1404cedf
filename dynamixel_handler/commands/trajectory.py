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
end (goal time tolerance). :class:`Follower` runs it from the loop and ends it at the next loop
when the bus adapter is gone. Angles are joint angles in radians, times in seconds.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from functools import cached_property
from itertools import chain
from typing import Sequence

import numpy as np

#: outcomes of a run (the FollowJointTrajectory result codes where one exists)
RUNNING, SUCCEEDED, PATH_VIOLATED, GOAL_VIOLATED = "running", "succeeded", "path_violated", "goal_violated"
#: how a run ends besides those: replaced by a newer one, cancelled, or unable to go on
PREEMPTED, CANCELLED, ABORTED = "preempted", "cancelled", "aborted"
#: most points a trajectory may have (a goal with more is refused before any other check): 10 s
#: of points every 10 ms. rclpy turns a goal into Python objects in this process before the
#: handler sees it (~10 us a point) while the loop waits for the interpreter lock: at 1,000 points
#: the loop's longest gap grows by at most a period at 100 Hz (10,000: 55 ms median, 170 ms worst
#: on the virtual bus). Points are kept as arrays and a loop's sample is one binary search
MAX_POINTS = 1_000


class TrajectoryError(ValueError):
    """A trajectory that cannot be followed; the message says why, for the caller."""


@dataclass(frozen=True)
class Points:
    """Checked points as arrays: ``times`` (m,), ``positions`` (m, n); ``velocities`` and
    ``accelerations`` (m, n) with the rows of points that do not give them zero and ``False`` in
    ``has_velocities`` / ``has_accelerations``."""

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    has_velocities: np.ndarray
    has_accelerations: np.ndarray

    def __len__(self) -> int:
        return len(self.times)

    @property
    def duration(self) -> float:
        """The last point's time from the start [s]."""
        return float(self.times[-1])

    @cached_property
    def coefficients(self) -> np.ndarray:
        """Polynomial coefficients of every segment between two points: (m - 1, 6, n)."""
        return _coefficients(self, slice(0, -1), slice(1, None))


@dataclass(frozen=True)
class Sample:
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


def make_points(n_joints: int, times: Sequence[float], positions: Sequence[Sequence[float]],
                velocities: Sequence[Sequence[float]], accelerations: Sequence[Sequence[float]]) -> Points:
    """Checked points: every point gives n positions (and n velocities / accelerations or none),
    times strictly increase, every number is finite. TrajectoryError naming the point otherwise."""
    if not len(times):
        raise TrajectoryError("the trajectory has no points")
    t = _times(times)
    p, _ = _joint_values("positions", positions, n_joints, required=True)
    v, has_v = _joint_values("velocities", velocities, n_joints)
    a, has_a = _joint_values("accelerations", accelerations, n_joints)
    alone = has_a & ~has_v
    if alone.any():
        raise TrajectoryError(f"point {int(np.argmax(alone))}: accelerations without velocities")
    points = Points(t, p, v, a, has_v, has_a)
    points.coefficients  # noqa: B018 - computed here, in the caller's thread, not in the loop's
    return points


def _times(times: Sequence[float]) -> np.ndarray:
    """The points' times as an array: each a time >= 0 after the one before."""
    t = np.asarray(times, dtype=np.float64)
    bad = ~np.isfinite(t) | (t < 0)
    if bad.any():
        k = int(np.argmax(bad))
        raise TrajectoryError(f"point {k}: time_from_start {t[k]} is not a time >= 0")
    late = np.flatnonzero(np.diff(t) <= 0)
    if len(late):
        k = int(late[0]) + 1
        raise TrajectoryError(f"point {k}: time_from_start {t[k]:g} s does not come after point {k - 1} ({t[k - 1]:g} s)")
    return t


def _joint_values(what: str, given: Sequence[Sequence[float]], n_joints: int,
                  required: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """One finite value per joint and point (``what``: positions, velocities, accelerations) as an
    (m, n) array, zero where a point gives none (allowed unless ``required``), and which points give them."""
    counts = np.fromiter((len(g) for g in given), dtype=np.int64, count=len(given))
    has = counts == n_joints
    wrong = ~has if required else ~has & (counts != 0)
    if wrong.any():
        k = int(np.argmax(wrong))
        raise TrajectoryError(f"point {k}: {counts[k]} {what} for {n_joints} joints")
    out = np.zeros((len(given), n_joints))
    if has.all():
        out[:] = np.fromiter(chain.from_iterable(given), dtype=np.float64,
                             count=len(given) * n_joints).reshape(len(given), n_joints)
    elif has.any():
        rows = np.flatnonzero(has)
        out[rows] = np.fromiter(chain.from_iterable(given[int(k)] for k in rows), dtype=np.float64,
                                count=len(rows) * n_joints).reshape(len(rows), n_joints)
    finite = np.isfinite(out).all(axis=1)
    if not finite.all():
        raise TrajectoryError(f"point {int(np.argmax(~finite))}: {what} are not all finite numbers")
    return out, has


def _coefficients(pts: Points, a: slice | list[int], b: slice | list[int]) -> np.ndarray:
    """Polynomial coefficients (segments, power 0..5, joints) of the segments from points ``a`` to
    points ``b``: a straight line where either end gives positions only, a cubic where both give
    velocities, a quintic where both also give accelerations."""
    p0, p1 = pts.positions[a], pts.positions[b]
    v0, v1 = pts.velocities[a], pts.velocities[b]
    a0, a1 = pts.accelerations[a], pts.accelerations[b]
    h = (pts.times[b] - pts.times[a])[:, None]
    cubic = (pts.has_velocities[a] & pts.has_velocities[b])[:, None]
    quintic = cubic & (pts.has_accelerations[a] & pts.has_accelerations[b])[:, None]
    c = np.zeros((len(h), 6, p0.shape[1]))
    c[:, 0] = p0
    c[:, 1] = np.where(cubic, v0, (p1 - p0) / h)
    c[:, 2] = np.where(quintic, a0 / 2, np.where(cubic, (3 * (p1 - p0) - (2 * v0 + v1) * h) / h ** 2, 0.0))
    c[:, 3] = np.where(quintic, (20 * (p1 - p0) - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h ** 2) / (2 * h ** 3),
                       np.where(cubic, (2 * (p0 - p1) + (v0 + v1) * h) / h ** 3, 0.0))
    c[:, 4] = np.where(quintic, (30 * (p0 - p1) + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h ** 2) / (2 * h ** 4), 0.0)
    c[:, 5] = np.where(quintic, (12 * (p1 - p0) - 6 * (v1 + v0) * h + (a1 - a0) * h ** 2) / (2 * h ** 5), 0.0)
    return c


def _lead(points: Points, start: np.ndarray, start_velocity: np.ndarray | None) -> np.ndarray:
    """The coefficients (6, n) of the segment from the joints' state at time 0 to the first point."""
    n = points.positions.shape[1]
    first = Points(np.array([0.0, points.times[0]]),
                   np.vstack([np.asarray(start, dtype=np.float64), points.positions[0]]),
                   np.vstack([np.zeros(n) if start_velocity is None else np.asarray(start_velocity, dtype=np.float64),
                              points.velocities[0]]),
                   np.vstack([np.zeros(n), points.accelerations[0]]),
                   np.array([True, bool(points.has_velocities[0])]), np.array([True, bool(points.has_accelerations[0])]))
    return _coefficients(first, [0], [1])[0]


_D1 = np.arange(6.0)
_D2 = np.array([0.0, 0.0, 2.0, 6.0, 12.0, 20.0])


class Trajectory:
    """Points joined by polynomial segments, starting from the joints' state at time 0. Building
    one costs the same for any number of points (the segments are the points' own)."""

    def __init__(self, points: Points, start: np.ndarray, start_velocity: np.ndarray | None = None) -> None:
        self.points = points
        self.times = points.times
        self.duration = points.duration
        #: from where the joints are to the first point, when it comes after time 0
        self._lead = _lead(points, start, start_velocity) if points.times[0] > 0 else None

    def sample(self, t: float) -> Sample:
        """Positions, velocities and accelerations at ``t`` seconds after the start."""
        pts = self.points
        if t >= self.duration:
            return Sample(pts.positions[-1].copy(), pts.velocities[-1].copy(), pts.accelerations[-1].copy())
        t = max(t, 0.0)
        if self._lead is not None and t < self.times[0]:
            c, s = self._lead, t
        else:
            k = int(np.searchsorted(self.times, t, side="right")) - 1
            c, s = pts.coefficients[k], t - self.times[k]
        powers = s ** _D1
        d1 = _D1 * np.concatenate(([0.0], powers[:5]))
        d2 = _D2 * np.concatenate(([0.0, 0.0], powers[:4]))
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
        goal = self.trajectory.points.positions[-1]
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
    points: Points
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
    is a :class:`~dynamixel_handler.commands.joint_goals.JointGoals`; a new job replaces (preempts) the old."""

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
        gone = self.device_gone()
        if gone:  # nothing can be commanded or judged: the goal ends now, the servos keep their goals
            self._finish(job, ABORTED, gone, hold=False)
            return
        stop = self.goals.h.figures().e_stop
        if stop is not None:  # the E-stop holds every servo already
            self._finish(job, ABORTED, f"ended: the E-stop was engaged ({stop}): the joints hold where they are",
                         hold=False)
            return
        apart = sorted(set(job.names) & self.goals.held)
        if apart:  # a joint of several servos whose servos disagree: held where each is already
            self._finish(job, ABORTED, f"ended: the servos of joint {apart[0]} disagree: it is held where each is",
                         hold=False)
            return
        now = time.time()
        if "position" in report.present and not self._judge(job, report.stamp):
            return
        self._command_ahead(job, now)

    def device_gone(self) -> str | None:
        """Why nothing reaches the servos now (the bus adapter vanished), or None."""
        h = self.goals.h
        if not h.figures().device_lost:
            return None
        return f"the device {h.settings.bus.device} is gone (unplugged?): the servos cannot be commanded"

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
