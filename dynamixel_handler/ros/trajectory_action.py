"""``~/follow_joint_trajectory`` (control_msgs/action/FollowJointTrajectory), served by the node.

MoveIt's simple controller manager (``type: FollowJointTrajectory``, ``action_ns:
follow_joint_trajectory`` under a controller named as this node) drives the servos through it
without ros2_control. Importing this module needs ``control_msgs``; the node imports it only when
``control_msgs`` is installed (``node.py``), and leaves the action out with one info line otherwise.

Every goal is accepted and then checked: a goal the handler cannot follow is aborted at once with
``INVALID_JOINTS`` (names not mapped, repeated, servo not handled, multi-DOF joints) or
``INVALID_GOAL`` (more than ``trajectory.MAX_POINTS`` points, points, times, a position beyond its
servo's position limits, tolerances, a trajectory already over or starting beyond
``joint_commands.START_HORIZON_S``, the bus adapter gone) and an ``error_string`` saying why. A
running goal ends with

- ``SUCCESSFUL`` (succeeded): every joint within its goal tolerance after the last point's time;
- ``PATH_TOLERANCE_VIOLATED`` (aborted): a joint left its path tolerance while running;
- ``GOAL_TOLERANCE_VIOLATED`` (aborted): not within the goal tolerance ``goal_time_tolerance``
  after the end;
- cancelled (``SUCCESSFUL``, cancelled): the joints hold where they are;
- preempted by a newer goal or ``joint_trajectory`` message (``SUCCESSFUL``, aborted, the
  ``error_string`` says so): the newer trajectory starts from where the joints are;
- the bus adapter gone (``INVALID_GOAL``, aborted, at the next loop; ``error_string``: the device
  is gone): the servos keep their last goals.

Feedback (desired, actual and error positions and velocities) goes out at ``FEEDBACK_HZ``.
"""
from __future__ import annotations

import ctypes
import math
import threading
import time
from typing import Any

from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from trajectory_msgs.msg import JointTrajectoryPoint

from ..commands import trajectory as tr
from ..commands.moves import MAX_JOBS
from ..logs import Throttle
from .convert import stamp_of
from .joint_commands import BAD_JOINTS, TrajectoryRefused, duration_s
from .services import QOS, RESULT_KEPT_S

#: feedback messages per second while a goal runs (at most one per read of the positions)
FEEDBACK_HZ = 20.0
#: a goal whose end has not been judged this long after its goal time ends (no reads) [s]
STALE_S = 2.0
#: a goal of at least this many points gives its memory back to the system once read (``trim_heap``)
TRIM_POINTS = 1000
R = FollowJointTrajectory.Result

CODES = {tr.SUCCEEDED: R.SUCCESSFUL, tr.PATH_VIOLATED: R.PATH_TOLERANCE_VIOLATED,
         tr.GOAL_VIOLATED: R.GOAL_TOLERANCE_VIOLATED, tr.PREEMPTED: R.SUCCESSFUL, tr.CANCELLED: R.SUCCESSFUL,
         tr.ABORTED: R.INVALID_GOAL}


class TrajectoryAction:
    def __init__(self, node, commands) -> None:
        self.node = node
        self.commands = commands
        self.follower = commands.follower
        self.log = node.get_logger()
        self.warn = Throttle(self.log.warning)
        self._lock = threading.Lock()
        self.waiting = 0  # goals accepted and not yet ended
        # the goal, result and cancel services keep as many requests as the other doors (rclpy's
        # default is 10: a crowd of clients lost most of its goals unanswered)
        self.server = ActionServer(node, FollowJointTrajectory, "~/follow_joint_trajectory",
                                   execute_callback=self._execute, goal_callback=self._accept,
                                   cancel_callback=lambda _g: CancelResponse.ACCEPT,
                                   callback_group=ReentrantCallbackGroup(), goal_service_qos_profile=QOS,
                                   result_service_qos_profile=QOS, cancel_service_qos_profile=QOS,
                                   result_timeout=RESULT_KEPT_S)

    def _accept(self, _goal) -> GoalResponse:
        """A goal is taken while fewer than MAX_JOBS wait (as the services' requests); beyond, it
        is rejected at once with a line, so a crowd's callers hear at once instead of timing out."""
        with self._lock:
            if self.waiting >= MAX_JOBS:
                full = self.waiting
            else:
                self.waiting += 1
                return GoalResponse.ACCEPT
        self.warn(f"follow_joint_trajectory: busy: {full} goals are waiting already: goal rejected (try again later)",
                  "trajectory queue full")
        return GoalResponse.REJECT

    def _execute(self, goal_handle) -> FollowJointTrajectory.Result:
        try:
            return self._follow(goal_handle)
        finally:
            with self._lock:
                self.waiting -= 1

    def _follow(self, goal_handle) -> FollowJointTrajectory.Result:
        g = goal_handle.request
        result = FollowJointTrajectory.Result()
        job, refused = self._job(g)
        _release(g)  # the job has its own copy: the server keeps the request until the result expires
        if job is None:
            kind, why = refused
            result.error_code = R.INVALID_JOINTS if kind == BAD_JOINTS else R.INVALID_GOAL
            result.error_string = why
            self.warn(f"follow_joint_trajectory: refused: {why}")
            goal_handle.abort()
            return result
        self.follower.start(job)
        self._watch(job, goal_handle)
        result.error_code = CODES[job.outcome]
        result.error_string = job.message
        if job.outcome == tr.SUCCEEDED:
            goal_handle.succeed()
        elif job.outcome == tr.CANCELLED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return result

    def _job(self, g: FollowJointTrajectory.Goal) -> tuple[tr.Job | None, tuple[str, str]]:
        """The goal's job, or None and why it is refused (kind, one line). Nothing of the goal is
        held after it returns (not even by an exception's frames), so ``_release`` frees it."""
        try:
            if g.multi_dof_trajectory.joint_names or g.multi_dof_trajectory.points:
                raise TrajectoryRefused(BAD_JOINTS, "multi-DOF joints are not handled (servos are single joints)")
            return self.commands.job("follow_joint_trajectory", g.trajectory, g.path_tolerance, g.goal_tolerance,
                                     duration_s(g.goal_time_tolerance)), ("", "")
        except TrajectoryRefused as err:
            return None, (err.kind, str(err))

    def _watch(self, job: tr.Job, goal_handle) -> None:
        """Feedback while the follower streams the trajectory; a cancel, a stopped loop or an end
        that is never judged stop it."""
        sent = None
        while not job.done.wait(1.0 / FEEDBACK_HZ):
            if goal_handle.is_cancel_requested:
                self.follower.stop(job, tr.CANCELLED, "cancelled: holding where the joints are")
                return
            if self.node.loop_stopped:
                self.follower.stop(job, tr.ABORTED, "the bus loop stopped")
                return
            late = time.time() - (job.start_wall + job.points.duration + job.tolerances.goal_time)
            if late > STALE_S:  # the end was never judged: no present positions came in (device gone?)
                self.follower.stop(job, tr.GOAL_VIOLATED, f"no present positions were read for {STALE_S:g} s after "
                                                          "the goal time: the goal cannot be confirmed")
                return
            last = job.last
            if last is not None and last is not sent:
                sent = last
                goal_handle.publish_feedback(self._feedback(job, last))

    def _feedback(self, job: tr.Job, last) -> FollowJointTrajectory.Feedback:
        t, verdict, present, velocity = last
        fb = FollowJointTrajectory.Feedback()
        fb.header.stamp = stamp_of(self.node.ros_time(job.start_wall + t))
        fb.joint_names = job.names
        desired = verdict.desired
        fb.desired = JointTrajectoryPoint(positions=desired.positions.tolist(), velocities=desired.velocities.tolist())
        fb.actual = JointTrajectoryPoint(positions=[float(p) for p in present], velocities=[float(v) for v in velocity])
        fb.error = JointTrajectoryPoint(
            positions=[float(a - d) if math.isfinite(a) else math.nan for a, d in zip(present, desired.positions)],
            velocities=[float(a - d) if math.isfinite(a) else math.nan for a, d in zip(velocity, desired.velocities)])
        return fb


def _release(goal: FollowJointTrajectory.Goal) -> None:
    """Drop the points of a goal that was read: rclpy keeps every goal request (and its points, a
    message object each) until its result expires, 15 minutes after the goal ends. After a large
    one, the C heap gives the pages it freed back to the system (``malloc_trim``)."""
    count = len(goal.trajectory.points) + len(goal.multi_dof_trajectory.points)
    goal.trajectory.points = []
    goal.multi_dof_trajectory.points = []
    if count >= TRIM_POINTS:
        trim_heap()


def trim_heap() -> None:
    """Give the free pages of the C heap back to the system (glibc; elsewhere nothing happens)."""
    global _trim
    if _trim is None:
        try:
            _trim = ctypes.CDLL(None).malloc_trim
        except (OSError, AttributeError):  # not glibc
            _trim = False
    if _trim:
        _trim(0)


#: glibc's malloc_trim once looked up; False where there is none
_trim: Any = None


def attach(node, commands) -> TrajectoryAction:
    return TrajectoryAction(node, commands)
