"""Torque and move services and the MoveJoints action.

``dynamixel/set_torque`` (SetTorque), ``dynamixel/move_to`` (MoveTo) and ``dynamixel/move_joints``
(MoveJoints) name servos by ID or by joint name. They never touch the bus themselves: every
check and write runs on the loop thread (``call_in_loop`` queues it and waits for the answer), and
moves go through the Commander, so the same validation and clamping apply as for the command
topics. Waiting happens on an executor thread of a ReentrantCallbackGroup, so topics, other
services and action cancels keep being served meanwhile (the node spins a MultiThreadedExecutor).
"""
from __future__ import annotations

import concurrent.futures
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup

from dynamixel_handler_msgs.action import MoveJoints
from dynamixel_handler_msgs.srv import MoveTo, SetTorque

from .. import units
from ..commands import Commander
from ..joints import JointMap, joint_map, resolve_targets
from ..loop import Handler

DEFAULT_TOLERANCE_DEG = 1.0
DEFAULT_TIMEOUT_S = 10.0
#: how often a waiting move looks at the present positions [s]
POLL_S = 0.02
#: least time between two feedback messages of the action [s]
FEEDBACK_S = 0.1
#: how long a request waits for the loop thread to take its operation [s]
LOOP_TIMEOUT_S = 5.0
#: modes whose goal is a position but that a move keeps (multi-turn); others switch to position mode
KEPT_POSITION_MODES = ("ex_position", "cur_position")
#: a servo that has not answered for this long ends a waiting move with ERROR [s] (one missed read does not)
SILENT_S = 0.5
#: how far a written goal may be from the requested one before the answer says so [deg]
GOAL_NOTE_DEG = 0.2

REACHED, TIMED_OUT, CANCELED, ERROR = (MoveJoints.Result.REACHED, MoveJoints.Result.TIMED_OUT,
                                       MoveJoints.Result.CANCELED, MoveJoints.Result.ERROR)


class MoveError(RuntimeError):
    """A request that cannot be carried out; the message says why, in words for the caller."""


def call_in_loop(handler: Handler, what: str, fn: Callable[[], object], timeout: float = LOOP_TIMEOUT_S):
    """Run ``fn`` on the loop thread and return its result (or raise its exception); MoveError
    when the loop does not take it in time (stopped, or an inactive lifecycle node)."""
    if handler.refuse_ops:  # e.g. an inactive lifecycle node: answer now, not after the timeout
        raise MoveError(f"'{what}' refused: {handler.refuse_ops}")
    fut: concurrent.futures.Future = concurrent.futures.Future()

    def op() -> None:
        if not fut.set_running_or_notify_cancel():
            return
        try:
            fut.set_result(fn())
        except BaseException as exc:  # handed to the caller
            fut.set_exception(exc)
    handler.queue(what, op)
    try:
        return fut.result(timeout)
    except concurrent.futures.TimeoutError:
        if fut.cancel():
            raise MoveError(f"the bus loop did not take '{what}' within {timeout:g} s (is the node active?)") from None
        return fut.result()


@dataclass
class Move:
    """One move under way: its servos, their goals [servo deg] and how to judge arrival."""

    targets: list[tuple[int, str | None]]
    requested_deg: list[float]
    tolerance_deg: float
    deadline: float
    goal_deg: list[float] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


class Motion:
    """Torque and moves on the handled servos, by ID or joint name (any thread; work in the loop)."""

    def __init__(self, handler: Handler, commander: Commander, mapping: JointMap | None,
                 running: Callable[[], bool] = lambda: True) -> None:
        self.h = handler
        self.commander = commander
        self.mapping = mapping
        self.running = running  # false once the loop stops: waiting moves end at once

    def targets(self, ids: Sequence[int], names: Sequence[str]) -> list[tuple[int, str | None]]:
        try:
            return resolve_targets(self.mapping, list(ids), list(names))
        except ValueError as err:
            raise MoveError(str(err)) from None

    def _unhandled(self, ids: Sequence[int]) -> list[int]:
        return [i for i in ids if i not in self.h.table]

    # ------------------------------------------------------------------ torque
    def set_torque(self, targets: list[tuple[int, str | None]], enable: bool) -> str:
        ids = [i for i, _ in targets]
        word = "on" if enable else "off"

        def op() -> str:
            missing = self._unhandled(ids)
            if missing:
                raise MoveError(f"IDs {missing} are not handled: nothing changed")
            failed = [i for i in ids if not (self.h.torque_on(i) if enable else self.h.torque_off(i))]
            if failed:
                raise MoveError(f"torque {word} failed on IDs {failed}: {self.h.bus.last_failure}")
            return f"torque {word}: IDs {ids}"
        return call_in_loop(self.h, f"torque {word}", op)

    # ------------------------------------------------------------------ moves
    def start(self, targets: list[tuple[int, str | None]], positions_deg: Sequence[float], velocity_deg_s: float,
              tolerance_deg: float, timeout_s: float) -> Move:
        """Check the request, hand the goals to the Commander, and return once they are written."""
        positions = _checked_request(targets, positions_deg, velocity_deg_s)
        ids = [i for i, _ in targets]
        mapping = self.mapping  # a joint name is only accepted with a mapping (``targets``)
        servo_deg = [mapping.to_servo_deg(name, p) if name is not None and mapping is not None else p
                     for (_, name), p in zip(targets, positions)]
        move = Move(targets, servo_deg, tolerance_deg if tolerance_deg > 0 else DEFAULT_TOLERANCE_DEG,
                    time.monotonic() + (timeout_s if timeout_s > 0 else DEFAULT_TIMEOUT_S))
        self._await_answers(ids)
        call_in_loop(self.h, "move", lambda: self._command(ids, servo_deg, velocity_deg_s))
        # the goals as written (or about to be, this step): clamped values included
        goals = call_in_loop(self.h, "move (goals written)", lambda: self._goals(ids))
        move.goal_deg = goals
        for (i, name), want, got in zip(targets, servo_deg, goals):
            if not math.isfinite(got) or abs(got - want) > GOAL_NOTE_DEG:
                move.notes.append(f"{name or f'ID {i}'}: goal is {got:.2f} deg (servo), not {want:.2f} "
                                  "(clamped to the servo's limits or refused: see the node's log)")
        return move

    def _await_answers(self, ids: list[int]) -> None:
        """Give servos that missed the last read (a loaded host, a noisy bus) time to answer before
        the move is refused: SILENT_S, plus the loops until a silent servo is pinged again. Returns
        at once when all answer; the check on the loop thread then decides."""
        grace = SILENT_S + self.h.recheck_loops * max(1.0 / self.h.config["loop_rate"], self.h.loop_period_s)
        deadline = time.monotonic() + grace

        def silent() -> list[int]:
            table = self.h.table
            return [i for i in ids if i in table and not table.ping[table.index[i]]]
        while self.running() and call_in_loop(self.h, "move (answers)", silent) and time.monotonic() < deadline:
            time.sleep(POLL_S)

    def _command(self, ids: list[int], servo_deg: list[float], velocity: float) -> None:
        """Loop thread: refuse servos that cannot move, then queue the goals per mode and series."""
        self._refuse_unready(ids)
        table = self.h.table
        batches: dict[tuple[str, str], tuple[list[int], list[float]]] = {}
        for i, deg in zip(ids, servo_deg):
            series = table.model(i).series
            kind = "goal" if self.h.mode(i) in KEPT_POSITION_MODES else "position_control"
            batch = batches.setdefault((kind, series), ([], []))
            batch[0].append(i)
            batch[1].append(deg)
        for (kind, series), (batch_ids, degs) in batches.items():
            fields: dict[str, list] = {"position_deg": degs}
            if velocity > 0:
                speed_field = "velocity_deg_s" if series == "PRO" and kind == "position_control" else "profile_vel_deg_s"
                fields[speed_field] = [velocity] * len(batch_ids)
            if kind == "goal":
                self.commander.goal(batch_ids, fields, what="move")
            else:
                self.commander.control(series, "position_control", batch_ids, fields)

    def _refuse_unready(self, ids: list[int]) -> None:
        """MoveError for servos that are not handled, do not answer or have no torque."""
        missing = self._unhandled(ids)
        if missing:
            raise MoveError(f"IDs {missing} are not handled")
        table = self.h.table
        silent = [i for i in ids if not table.ping[table.index[i]]]
        if silent:
            raise MoveError(f"IDs {silent} do not answer")
        off = [i for i in ids if not (table.value("torque_enable", i) or self.h.read_item(i, "torque_enable"))]
        if off:
            raise MoveError(f"torque is off on IDs {off}: enable it first (set_torque)")

    def _goals(self, ids: list[int]) -> list[float]:
        """Goals the servos go to: written ones, or those still waiting for this step's write."""
        table = self.h.table
        goal = table.units("goal_position")
        pending = self.h.pending.peek("goal_position")
        out = []
        for i in ids:
            if i not in table:
                out.append(math.nan)
            elif i in pending:
                out.append(float(units.pulse_to_unit([table.model(i)], "goal_position", [pending[i]])[0]))
            else:
                out.append(float(goal[table.index[i]]))
        return out

    def probe(self, move: Move) -> tuple[list[float], list[bool]]:
        """Present positions [servo deg] and pings of the move's servos, as last read."""
        ids = [i for i, _ in move.targets]

        def op() -> tuple[list[float], list[bool]]:
            table = self.h.table
            present = table.units("present_position")
            pos = [table.index.get(i) for i in ids]
            return ([float(present[p]) if p is not None else math.nan for p in pos],
                    [bool(table.ping[p]) if p is not None else False for p in pos])
        return call_in_loop(self.h, "move (progress)", op)

    def hold(self, move: Move) -> None:
        """Stop where the servos are: goal := present position (through the Commander)."""
        present, _ = self.probe(move)
        keep = [(i, p) for (i, _), p in zip(move.targets, present) if math.isfinite(p)]
        if keep:
            self.commander.goal([i for i, _ in keep], {"position_deg": [p for _, p in keep]}, what="move cancelled")

    def in_request_frame(self, move: Move, servo_deg: Sequence[float]) -> list[float]:
        mapping = self.mapping
        return [mapping.to_joint_deg(name, d) if name is not None and mapping is not None else d
                for (_, name), d in zip(move.targets, servo_deg)]

    def follow(self, move: Move, cancelled: Callable[[], bool] = lambda: False,
               feedback: Callable[[list[float], list[float]], None] | None = None) -> tuple[int, str, list[float]]:
        """Wait until every servo is within tolerance of its goal, the deadline, a silent servo or
        a cancel; (outcome, message, present positions in the request's frame)."""
        watch = _Watch(move)
        last_feedback = 0.0
        while True:
            if not self.running():
                return ERROR, "the bus loop stopped", []
            present, ping = self.probe(move)
            remaining = [abs(p - g) if math.isfinite(p) and math.isfinite(g) else math.inf
                         for p, g in zip(present, move.goal_deg)]
            shown = self.in_request_frame(move, present)
            now = time.monotonic()
            if feedback is not None and now - last_feedback >= FEEDBACK_S:
                feedback(shown, remaining)
                last_feedback = now
            verdict = watch.verdict(ping, remaining, now, cancelled)
            if verdict is not None:
                return verdict[0], verdict[1], shown
            time.sleep(POLL_S)


class _Watch:
    """How a waiting move ends: a servo silent for SILENT_S, every servo within tolerance, a
    cancel, or the deadline (in that order)."""

    def __init__(self, move: Move) -> None:
        self.move = move
        self.names = [name or f"ID {i}" for i, name in move.targets]
        self.silent_since: dict[int, float] = {}

    def verdict(self, ping: list[bool], remaining: list[float], now: float,
                cancelled: Callable[[], bool]) -> tuple[int, str] | None:
        move = self.move
        silent = self._silent(ping, now)
        if silent:
            return ERROR, f"{', '.join(silent)} stopped answering"
        if not self.silent_since and all(r <= move.tolerance_deg for r in remaining):
            return REACHED, _with_notes(f"reached within {move.tolerance_deg:g} deg", move)
        if cancelled():
            return CANCELED, "cancelled: stopped where the servos were"
        if now >= move.deadline:
            far = [f"{n} {r:.1f} deg away" for n, r in zip(self.names, remaining) if r > move.tolerance_deg]
            return TIMED_OUT, _with_notes(f"timed out: {', '.join(far)}", move)
        return None

    def _silent(self, ping: list[bool], now: float) -> list[str]:
        """The servos that have not answered for SILENT_S (one missed read does not count)."""
        for k, ok in enumerate(ping):
            if ok:
                self.silent_since.pop(k, None)
            else:
                self.silent_since.setdefault(k, now)
        return [self.names[k] for k, since in sorted(self.silent_since.items()) if now - since >= SILENT_S]


def _checked_request(targets: list[tuple[int, str | None]], positions_deg: Sequence[float],
                     velocity_deg_s: float) -> list[float]:
    """The positions as floats; MoveError for a request that cannot be right."""
    positions = [float(p) for p in positions_deg]
    if len(positions) != len(targets):
        raise MoveError(f"{len(positions)} positions for {len(targets)} servos")
    bad = [name or i for (i, name), p in zip(targets, positions) if not math.isfinite(p)]
    if bad:
        raise MoveError(f"positions of {bad} are not finite numbers")
    if not math.isfinite(velocity_deg_s) or velocity_deg_s < 0:
        raise MoveError(f"velocity {velocity_deg_s} must be a finite value >= 0")
    ids = [i for i, _ in targets]
    if len(set(ids)) != len(ids):
        raise MoveError(f"a servo is named twice in {ids}")
    return positions


def _with_notes(message: str, move: Move) -> str:
    return "; ".join([message] + move.notes)


class MotionServices:
    """The ROS side: services and the action on one node."""

    def __init__(self, node) -> None:
        self.node = node
        self.log = node.get_logger()
        self.motion = Motion(node.handler, node.commander, joint_map(node.config.values),
                             running=lambda: not node.loop_stopped)
        group = ReentrantCallbackGroup()
        node.create_service(SetTorque, "dynamixel/set_torque", self._on_set_torque, callback_group=group)
        node.create_service(MoveTo, "dynamixel/move_to", self._on_move_to, callback_group=group)
        self.action = ActionServer(node, MoveJoints, "dynamixel/move_joints", execute_callback=self._execute,
                                   goal_callback=lambda _goal: GoalResponse.ACCEPT,
                                   cancel_callback=lambda _goal: CancelResponse.ACCEPT, callback_group=group)

    def _on_set_torque(self, req: SetTorque.Request, res: SetTorque.Response) -> SetTorque.Response:
        try:
            res.message = self.motion.set_torque(self.motion.targets(req.ids, req.joint_names), bool(req.enable))
            res.success = True
        except MoveError as err:
            res.success, res.message = False, str(err)
            self.log.warning(f"set_torque: {err}")
        return res

    def _on_move_to(self, req: MoveTo.Request, res: MoveTo.Response) -> MoveTo.Response:
        try:
            move = self.motion.start(self.motion.targets(req.ids, req.joint_names), req.positions_deg,
                                     req.profile_vel_deg_s, req.tolerance_deg, req.timeout_s)
            if req.wait:
                outcome, res.message, shown = self.motion.follow(move)
                res.reached = outcome == REACHED
                res.success = res.reached
            else:
                shown = self.motion.in_request_frame(move, self.motion.probe(move)[0])
                res.success, res.reached = True, False
                res.message = _with_notes("goals written", move)
            res.positions_deg = shown
        except MoveError as err:
            res.success, res.reached, res.message = False, False, str(err)
            self.log.warning(f"move_to: {err}")
        return res

    def _execute(self, goal_handle) -> MoveJoints.Result:
        g = goal_handle.request
        result = MoveJoints.Result()
        try:
            move = self.motion.start(self.motion.targets(g.ids, g.joint_names), g.positions_deg,
                                     g.velocity_limit_deg_s, g.tolerance_deg, g.timeout_s)

            def feedback(positions: list[float], remaining: list[float]) -> None:
                goal_handle.publish_feedback(MoveJoints.Feedback(positions_deg=positions, remaining_deg=remaining))
            outcome, result.message, shown = self.motion.follow(
                move, cancelled=lambda: goal_handle.is_cancel_requested, feedback=feedback)
            if outcome == CANCELED:
                self.motion.hold(move)
            result.status, result.positions_deg = outcome, shown
        except MoveError as err:
            result.status, result.message = ERROR, str(err)
            self.log.warning(f"move_joints: {err}")
        if result.status == REACHED:
            goal_handle.succeed()
        elif result.status == CANCELED:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return result


def attach(node) -> MotionServices:
    return MotionServices(node)
