"""Torque, move and reboot services and the MoveJoints action.

``dynamixel/set_torque`` (SetTorque), ``dynamixel/move_to`` (MoveTo) and ``dynamixel/move_joints``
(MoveJoints) name servos by ID or by joint name; ``dynamixel/reboot`` (std_srvs/Trigger) reboots
the servos in hardware error (``reboot_job``). A request is checked at once (``move_checks``)
and refused with one line, limited to one a second per cause, when it names a servo twice, more
servos than the node handles, an unknown joint, or positions that are not numbers. What needs the
bus is a job the loop thread carries out after its steps (``moves.Book``); moves go through the
Commander, so the same validation and clamping apply as for the command topics.

The callbacks are coroutines: while a job is under way they yield to the executor instead of
holding one of its threads, so any number of waiting calls and goals leave the executor free for
topics, other services, goal requests and cancels. rclpy 7 (Jazzy) resumes a pending coroutine
whenever its executor wakes up; the Book wakes it (a guard condition) when a job ends and, while
goals want feedback, every ``moves.FEEDBACK_S``; a timer wakes it while jobs wait, so that a job
the loop does not judge in time is answered all the same (``Book.expire``).
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Sequence

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.srv import CalibrateOffsets, MoveTo, SetTorque

from ..commands.calibrate_job import CalibrateJob
from ..commands.move_checks import checked_positions, targets_of
from ..commands.moves import (
    CANCELED,
    DONE,
    ERROR,
    FEEDBACK_S,
    LOOP_TIMEOUT_S,
    PREEMPTED,
    REACHED,
    TIMED_OUT,
    Book,
    Job,
    MoveError,
    MoveJob,
    TorqueJob,
    new_move,
)
from ..commands.reboot_job import RebootJob
from ..joints.calibration import Calibration
from ..logs import Throttle
from . import calibration

#: requests (and answers) each service keeps queued: a burst of calls is not dropped for want of room
QUEUE_DEPTH = 1000
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)
#: how long the result of an ended goal is kept for a client that asks for it late [s]
RESULT_KEPT_S = 60
#: how often the executor is woken while jobs wait, so that overdue ones are answered [s]
EXPIRE_CHECK_S = 0.2
#: longest wait of ``dynamixel/reboot`` for the loop: each servo in error boots and is read again [s]
REBOOT_ANSWER_S = 30.0

#: MoveJoints' status of each end (PREEMPTED: ERROR, the message says so)
STATUS = {REACHED: MoveJoints.Result.REACHED, TIMED_OUT: MoveJoints.Result.TIMED_OUT,
          CANCELED: MoveJoints.Result.CANCELED, ERROR: MoveJoints.Result.ERROR, PREEMPTED: MoveJoints.Result.ERROR,
          DONE: MoveJoints.Result.REACHED}


class _Pause:
    """Awaited by a callback coroutine: gives its executor thread back until the next wake-up."""

    def __await__(self):
        yield


class MotionServices:
    """The ROS side: services and the action on one node."""

    def __init__(self, node) -> None:
        self.node = node
        self.log = node.get_logger()
        self.warn = Throttle(self.log.warning)
        self.group = group = ReentrantCallbackGroup()  # every service and action of the node's motion
        self._guard = node.create_guard_condition(lambda: None, callback_group=group)
        self.book = Book(node.handler, node.commander, node.joints, wake=self._wake)
        node.handler.attach(self.book)  # the jobs' steps, queued by the jobs, taken in the loop thread
        node.step_hooks.append(self.book.on_step)
        self._timer = node.create_timer(EXPIRE_CHECK_S, self._tick, callback_group=group)
        self._timer.cancel()  # runs only while jobs wait
        node.create_service(SetTorque, "dynamixel/set_torque", self._on_set_torque, qos_profile=QOS,
                            callback_group=group)
        node.create_service(MoveTo, "dynamixel/move_to", self._on_move_to, qos_profile=QOS,
                            callback_group=group)
        from std_srvs.srv import Trigger
        node.create_service(Trigger, "dynamixel/reboot", self._on_reboot, qos_profile=QOS, callback_group=group)
        self._saving = threading.Lock()  # calibrations saved one after the other, the latest last
        if node.joints is not None:
            node.create_service(CalibrateOffsets, "dynamixel/calibrate_offsets", self._on_calibrate, qos_profile=QOS,
                                callback_group=group)
        self.action = ActionServer(node, MoveJoints, "dynamixel/move_joints", execute_callback=self._execute,
                                   goal_callback=lambda _goal: GoalResponse.ACCEPT,
                                   cancel_callback=lambda _goal: CancelResponse.ACCEPT, callback_group=group,
                                   goal_service_qos_profile=QOS, result_service_qos_profile=QOS,
                                   cancel_service_qos_profile=QOS, result_timeout=RESULT_KEPT_S)

    # ------------------------------------------------------------------ waiting without a thread
    def _wake(self) -> None:
        try:
            self._guard.trigger()
        except Exception:  # the node is being destroyed: nobody waits any more
            pass

    def _tick(self) -> None:
        with self.book.lock:
            if not self.book.jobs:
                self._timer.cancel()

    def targets(self, ids: Sequence[int], names: Sequence[str], moves: bool = True, positions: bool = True):
        """The servos named; MoveError (answered at once) when the node cannot take the request."""
        self._taken(moves)
        return targets_of(self.book.mapping, ids, names, len(self.node.handler.table), positions)

    def _taken(self, moves: bool) -> None:
        """MoveError when the node cannot take a request now: inactive, its loop stopped, or (a
        request that ``moves``: a move, torque on) the E-stop engaged."""
        refused = self.node.handler.refuse_ops  # e.g. an inactive lifecycle node: answer now
        if refused:
            raise MoveError(f"refused: {refused}")
        if self.node.loop_stopped:
            raise MoveError("refused: the bus loop stopped")
        stop = self.node.handler.figures().e_stop
        if moves and stop is not None:
            raise MoveError(f"refused: the E-stop is engaged ({stop}); release it first")

    async def settle(self, job: Job, on_resume: Callable[[], None] | None = None) -> None:
        """Until ``job`` has ended: the loop ends it, or it is answered when overdue."""
        self.book.add(job)
        with self.book.lock:
            if self._timer.is_canceled():
                self._timer.reset()
        while not job.finished:
            if self.node.loop_stopped:
                self.book.finish(job, ERROR, "the bus loop stopped")
            self.book.expire(job, time.monotonic())
            if on_resume is not None:
                on_resume()
            if job.finished:
                break
            await _Pause()

    # ------------------------------------------------------------------ callbacks
    async def _on_set_torque(self, req: SetTorque.Request, res: SetTorque.Response) -> SetTorque.Response:
        try:
            # torque off moves nothing; a joint of several servos: each of them
            targets = self.targets(req.ids, req.joint_names, moves=bool(req.enable), positions=False)
            job = TorqueJob([i for i, _ in targets], bool(req.enable), time.monotonic() + LOOP_TIMEOUT_S)
            await self.settle(job)
            res.success, res.message = job.outcome == DONE, job.message
        except MoveError as err:
            res.success, res.message = False, str(err)
        if not res.success:
            self.warn(f"set_torque: {res.message}")
        return res

    async def _on_reboot(self, _req, res):
        """The servos in hardware error rebooted, each named with its outcome; the others untouched."""
        try:
            self._taken(moves=False)  # the node active, its loop running
            job = RebootJob(time.monotonic() + REBOOT_ANSWER_S)
            await self.settle(job)
            res.success, res.message = job.outcome == DONE, job.message
        except MoveError as err:
            res.success, res.message = False, str(err)
        (self.log.info if res.success else self.warn)(f"reboot: {res.message}")
        return res

    async def _on_calibrate(self, req: CalibrateOffsets.Request, res: CalibrateOffsets.Response) -> CalibrateOffsets.Response:
        """Joint offsets from an external measurement, set by the loop between two steps
        (``CalibrateJob``), then saved here, off the loop."""
        res.success = res.saved = False
        try:
            self._taken(moves=False)  # nothing moves: an engaged E-stop does not stop it
            joints = self.node.joints
            request = Calibration(tuple(req.joint_names), tuple(float(p) for p in req.positions))
            why = request.refusal(joints.map)
            if why:
                raise MoveError(f"refused: {why}: no offset changed")
            commands = getattr(self.node, "joint_commands", None)
            job = CalibrateJob(request, joints, commands.follower if commands is not None else None,
                               time.monotonic() + LOOP_TIMEOUT_S)
            await self.settle(job)
            res.success, res.message, res.offsets = job.outcome == DONE, job.message, job.positions
            if res.success:
                with self._saving:  # the map in use now: a later calibration's save is never overwritten
                    res.saved, res.path, note = calibration.save(self.node, joints.map)
                res.message += f" ({note})"
        except MoveError as err:
            res.message = str(err)
        (self.log.info if res.success else self.warn)(f"calibrate_offsets: {res.message}")
        return res

    async def _on_move_to(self, req: MoveTo.Request, res: MoveTo.Response) -> MoveTo.Response:
        try:
            targets = self.targets(req.ids, req.joint_names)
            positions = checked_positions(targets, req.positions_deg, req.profile_vel_deg_s)
            job = new_move(self.book, targets, positions, req.profile_vel_deg_s, req.tolerance_deg, req.timeout_s,
                           wait=bool(req.wait))
            await self.settle(job)
            res.success = job.outcome in (REACHED, DONE)
            res.reached = job.outcome == REACHED
            res.message, res.positions_deg = job.message, job.positions
        except MoveError as err:
            res.success, res.reached, res.message = False, False, str(err)
        if not res.success:
            self.warn(f"move_to: {res.message}")
        return res

    async def _execute(self, goal_handle) -> MoveJoints.Result:
        g = goal_handle.request
        result = MoveJoints.Result()
        try:
            targets = self.targets(g.ids, g.joint_names)
            positions = checked_positions(targets, g.positions_deg, g.velocity_limit_deg_s)
            job = new_move(self.book, targets, positions, g.velocity_limit_deg_s, g.tolerance_deg, g.timeout_s,
                           wait=True, feedback=True)
            await self.settle(job, lambda: self._goal_news(goal_handle, job))
            outcome = ERROR if job.outcome is None else job.outcome
            result.status, result.message, result.positions_deg = STATUS[outcome], job.message, job.positions
        except MoveError as err:
            result.status, result.message, outcome = MoveJoints.Result.ERROR, str(err), ERROR
        if outcome not in (REACHED, CANCELED):
            self.warn(f"move_joints: {result.message}")
        if outcome == REACHED:
            goal_handle.succeed()
        elif outcome == CANCELED:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return result

    def _goal_news(self, goal_handle, job: MoveJob) -> None:
        """On each wake-up: a cancel asked for goes to the job; new feedback goes out."""
        if goal_handle.is_cancel_requested and not job.cancel_requested:
            job.cancel_requested = True
        now = time.monotonic()
        if job.feedback is None or now - job.feedback_sent < FEEDBACK_S:
            return
        news, job.feedback, job.feedback_sent = job.feedback, None, now
        if goal_handle.is_active:
            goal_handle.publish_feedback(MoveJoints.Feedback(positions_deg=news[0], remaining_deg=news[1]))


def attach(node) -> MotionServices:
    return MotionServices(node)
