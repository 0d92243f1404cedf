"""Torque changes and moves asked for by the services and the action, carried out by the loop thread.

A checked request becomes a job in the ``Book``. The loop thread advances every job after each
step (a step hook, with the table just read): a move waits briefly for servos that missed a read,
is written through the Commander (queued for the next step, so the same validation and clamping
apply as for the command topics), then judged against the positions read each loop until it is
reached, times out, is cancelled, or a servo goes silent. A torque change is written a few servos
a step, within half a loop period, so that no request costs the loop more than one period.

Nobody blocks: the ROS side (``services.py``) awaits the job in a coroutine that holds no
executor thread, and the Book wakes the executor when jobs end (and for feedback). A job whose
loop does not judge it in time is answered all the same (``expire``).

Several callers on the same servo: the later move wins. When its goals are written, every other
unfinished move naming one of its servos ends ``PREEMPTED`` (its other servos keep the goals it
gave them); a move that starts after a later one on a shared servo already did is preempted at
once and writes nothing. Commands from the topics and trajectories do not end a waiting move.
"""
from __future__ import annotations

import math
import threading
import time
from collections import deque
from typing import Callable, Sequence

from .. import units
from ..commands import Commander
from ..joints import JointMap
from ..logs import some_ids
from ..loop import Handler
from .move_checks import (
    CANCELED,
    DEFAULT_TIMEOUT_S,
    DEFAULT_TOLERANCE_DEG,
    DONE,
    ERROR,
    PREEMPTED,
    REACHED,
    SILENT_S,
    TIMED_OUT,
    Move,
    MoveError,
    Targets,
    Watch,
    listed,
    with_notes,
)

__all__ = ["Book", "Job", "MoveJob", "TorqueJob", "CANCELED", "DONE", "ERROR", "PREEMPTED", "REACHED", "TIMED_OUT",
           "MoveError"]

#: modes whose goal is a position but that a move keeps (multi-turn); others switch to position mode
KEPT_POSITION_MODES = ("ex_position", "cur_position")
#: how far a written goal may be from the requested one before the answer says so [deg]
GOAL_NOTE_DEG = 0.2
#: how long a job that needs no waiting may take the loop to carry out before it is answered anyway [s]
LOOP_TIMEOUT_S = 5.0
#: least time between two wake-ups of the executor for feedback [s]
FEEDBACK_S = 0.1
#: requests waiting at once; beyond, a request is refused at once
MAX_JOBS = 512


class Job:
    """A request the loop thread carries out; ended once (``finish``), the first end wins."""

    seq = 0

    def __init__(self, what: str, ids: list[int], answer_by: float) -> None:
        Job.seq += 1
        self.seq = Job.seq
        self.what = what
        self.ids = ids
        self.answer_by = answer_by  # answered by then even if the loop never gets to it
        self.claimed = False  # the loop thread has begun bus work for it
        self.outcome: int | None = None
        self.message = ""
        self.positions: list[float] = []

    @property
    def finished(self) -> bool:
        return self.outcome is not None

    def advance(self, book: Book, now: float) -> None:  # loop thread, after a step
        raise NotImplementedError

    def overdue(self) -> tuple[int, str]:
        return ERROR, f"the bus loop did not carry out '{self.what}' in time: nothing was written"


class TorqueJob(Job):
    def __init__(self, ids: list[int], enable: bool, answer_by: float) -> None:
        super().__init__(f"torque {'on' if enable else 'off'}", ids, answer_by)
        self.enable = enable
        self.todo = deque(ids)
        self.failed: list[int] = []
        self.queued = False

    def advance(self, book: Book, now: float) -> None:
        if not self.queued:
            self.queued = True
            book.h.queue(self.what, lambda: self._write(book))

    def _write(self, book: Book) -> None:
        """Loop thread: the next servos, within half a period (at least one)."""
        self.queued = False
        if not self.claimed and not self._begin(book):
            return
        h = book.h
        end = time.perf_counter() + 0.5 * book.period_s
        while self.todo and not self.finished:
            dxl_id = self.todo.popleft()
            if not (h.torque_on(dxl_id) if self.enable else h.torque_off(dxl_id)):
                self.failed.append(dxl_id)
            if time.perf_counter() > end:
                break
        if self.todo:
            return
        if self.failed:
            book.finish(self, ERROR, f"{self.what} failed on IDs [{listed(self.failed)}]: {h.bus.last_failure}")
        else:
            book.finish(self, DONE, f"{self.what}: IDs [{listed(self.ids)}]")

    def _begin(self, book: Book) -> bool:
        """Every servo handled (else nothing changes) and the job still wanted."""
        missing = [i for i in self.ids if i not in book.h.table]
        if missing:
            book.finish(self, ERROR, f"IDs [{listed(missing)}] are not handled: nothing changed")
            return False
        return book.claim(self)

    def overdue(self) -> tuple[int, str]:
        if not self.claimed:
            return super().overdue()
        done = [i for i in self.ids if i not in self.todo]
        return ERROR, f"{self.what}: the bus loop did not finish in time: done on IDs {some_ids(done)}"


class MoveJob(Job):
    """A move: waits for answers, is written, then (with ``wait``) judged every loop."""

    def __init__(self, move: Move, velocity: float, wait: bool, grace_until: float, answer_by: float,
                 feedback: bool = False) -> None:
        super().__init__("move", move.ids, answer_by)
        self.move = move
        self.velocity = velocity
        self.wait = wait
        self.grace_until = min(grace_until, move.deadline)
        self.state = "answers"  # -> "writing" -> "following"
        self.watch = Watch(move)
        self.cancel_requested = False
        self.want_feedback = feedback
        self.feedback: tuple[list[float], list[float]] | None = None  # latest (positions, remaining)

    def advance(self, book: Book, now: float) -> None:
        if self.state == "answers":
            table = book.h.table
            silent = [i for i in self.ids if i in table and not table.ping[table.index[i]]]
            if not silent or now >= self.grace_until:
                self.state = "writing"
                book.h.queue("move", lambda: book.start(self))
        elif self.state == "following":
            self._judge(book, now)

    def _judge(self, book: Book, now: float) -> None:
        """Loop thread, after a step: feedback, and the end once there is one."""
        present, ping = book.probe(self.ids)
        remaining = [abs(p - g) if math.isfinite(p) and math.isfinite(g) else math.inf
                     for p, g in zip(present, self.move.goal_deg)]
        shown = book.in_request_frame(self.move, present)
        if self.want_feedback:
            self.feedback = (shown, remaining)
        verdict = self.watch.verdict(ping, remaining, now, lambda: self.cancel_requested)
        if verdict is not None:
            if verdict[0] == CANCELED:
                book.hold(self.ids, present)
            book.finish(self, verdict[0], verdict[1], shown)

    def overdue(self) -> tuple[int, str]:
        if not self.claimed:
            return super().overdue()
        return TIMED_OUT, with_notes("timed out: the bus loop read no positions in time", self.move)


class Book:
    """The jobs under way (any thread adds; the loop thread advances them after each step)."""

    def __init__(self, handler: Handler, commander: Commander, mapping: JointMap | None,
                 wake: Callable[[], None] = lambda: None) -> None:
        self.h = handler
        self.commander = commander
        self.mapping = mapping
        self.wake = wake  # called when jobs ended or feedback is due (wakes the executor)
        self.jobs: list[Job] = []
        self.lock = threading.Lock()
        self._last_feedback = 0.0

    @property
    def period_s(self) -> float:
        return 1.0 / float(self.h.config["loop_rate"])

    @property
    def grace_s(self) -> float:
        """How long a move waits for servos that missed the last read (a loaded host, a noisy bus)
        before it is refused: SILENT_S, plus the loops until a silent servo is pinged again."""
        return SILENT_S + self.h.recheck_loops * max(self.period_s, self.h.loop_period_s)

    # ------------------------------------------------------------------ any thread
    def add(self, job: Job) -> None:
        with self.lock:
            if len(self.jobs) >= MAX_JOBS:
                raise MoveError(f"{len(self.jobs)} requests are waiting already: try again later")
            self.jobs.append(job)

    def finish(self, job: Job, outcome: int, message: str, positions: Sequence[float] = ()) -> bool:
        """End ``job`` (once); True if this call ended it."""
        with self.lock:
            if job.finished:
                return False
            job.positions = list(positions)
            job.message = message
            job.outcome = outcome
            if job in self.jobs:
                self.jobs.remove(job)
        self.wake()
        return True

    def claim(self, job: Job) -> bool:
        """Loop thread: mark ``job`` as begun on the bus, unless it has ended meanwhile."""
        with self.lock:
            if job.finished:
                return False
            job.claimed = True
            return True

    def expire(self, job: Job, now: float) -> None:
        """Answer a job the loop did not end by its time (a stopped or stalled loop)."""
        if not job.finished and now > job.answer_by:
            self.finish(job, *job.overdue())

    # ------------------------------------------------------------------ loop thread
    def on_step(self, _report: object = None) -> None:
        """Step hook: advance every job (an ended one wakes the executor); wake it for feedback."""
        if not self.jobs:
            return
        now = time.monotonic()
        with self.lock:
            jobs = list(self.jobs)
        feedback = False
        for job in jobs:
            try:
                job.advance(self, now)
            except MoveError as err:
                self.finish(job, ERROR, str(err))
            except Exception as exc:  # a job must never stop the loop
                self.finish(job, ERROR, f"{job.what} failed: {type(exc).__name__}: {exc}")
            feedback = feedback or isinstance(job, MoveJob) and job.want_feedback and not job.finished
        if feedback and now - self._last_feedback >= FEEDBACK_S:
            self._last_feedback = now
            self.wake()

    def start(self, job: MoveJob) -> None:
        """Queued operation: refuse servos that cannot move, write the goals, preempt other moves."""
        try:
            if job.finished or self._superseded(job) or not self.claim(job):
                return
            self._refuse_unready(job.ids)
            self._command(job.ids, job.move.requested_deg, job.velocity)
        except MoveError as err:
            self.finish(job, ERROR, str(err))
            return
        self._preempt(job)
        # the goals as written (or about to be, this step): after the Commander's operations above
        self.h.queue("move (goals written)", lambda: self._written(job))

    def _superseded(self, job: MoveJob) -> bool:
        """A later move on a shared servo is already written: ``job`` ends PREEMPTED unwritten."""
        mine = set(job.ids)
        with self.lock:
            later = [j for j in self.jobs if j.seq > job.seq and j.claimed and isinstance(j, MoveJob)
                     and mine.intersection(j.ids)]
        if not later:
            return False
        shared = sorted(mine.intersection(later[0].ids))
        self.finish(job, PREEMPTED, f"preempted before it started: a later move of IDs {some_ids(shared)} "
                                    "came first; nothing was written")
        return True

    def _preempt(self, job: MoveJob) -> None:
        mine = set(job.ids)
        with self.lock:
            older = [j for j in self.jobs if j.seq < job.seq and isinstance(j, MoveJob) and mine.intersection(j.ids)]
        for other in older:
            shared = sorted(mine.intersection(other.ids))
            keep = [i for i in other.ids if i not in mine]
            rest = f"; IDs {some_ids(keep)} keep their goals" if keep and other.claimed else ""
            self.finish(other, PREEMPTED, f"preempted by a later move of ID{'s' if len(shared) > 1 else ''} "
                                          f"{some_ids(shared)}{rest}")

    def _written(self, job: MoveJob) -> None:
        move = job.move
        move.goal_deg = self._goals(job.ids)
        for (i, name), want, got in zip(move.targets, move.requested_deg, move.goal_deg):
            if not math.isfinite(got) or abs(got - want) > GOAL_NOTE_DEG:
                move.notes.append(f"{name or f'ID {i}'}: goal is {got:.2f} deg (servo), not {want:.2f} "
                                  "(clamped to the servo's limits or refused: see the node's log)")
        if job.wait:
            job.state = "following"
            return
        present, _ = self.probe(job.ids)
        self.finish(job, DONE, with_notes("goals written", move), self.in_request_frame(move, present))

    def _command(self, ids: list[int], servo_deg: list[float], velocity: float) -> None:
        """Queue the goals per mode and series (the Commander writes them this step)."""
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
        missing = [i for i in ids if i not in self.h.table]
        if missing:
            raise MoveError(f"IDs [{listed(missing)}] are not handled")
        table = self.h.table
        silent = [i for i in ids if not table.ping[table.index[i]]]
        if silent:
            raise MoveError(f"IDs [{listed(silent)}] do not answer")
        off = [i for i in ids if not (table.value("torque_enable", i) or self.h.read_item(i, "torque_enable"))]
        if off:
            raise MoveError(f"torque is off on IDs [{listed(off)}]: enable it first (set_torque)")

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

    def probe(self, ids: list[int]) -> tuple[list[float], list[bool]]:
        """Present positions [servo deg] and pings of ``ids``, as last read."""
        table = self.h.table
        present = table.units("present_position")
        pos = [table.index.get(i) for i in ids]
        return ([float(present[p]) if p is not None else math.nan for p in pos],
                [bool(table.ping[p]) if p is not None else False for p in pos])

    def hold(self, ids: list[int], present: list[float]) -> None:
        """Stop where the servos are: goal := present position (through the Commander)."""
        keep = [(i, p) for i, p in zip(ids, present) if math.isfinite(p)]
        if keep:
            self.commander.goal([i for i, _ in keep], {"position_deg": [p for _, p in keep]}, what="move cancelled")

    def in_request_frame(self, move: Move, servo_deg: Sequence[float]) -> list[float]:
        mapping = self.mapping
        return [mapping.to_joint_deg(name, d) if name is not None and mapping is not None else d
                for (_, name), d in zip(move.targets, servo_deg)]


def new_move(book: Book, targets: Targets, positions: list[float], velocity: float, tolerance_deg: float,
             timeout_s: float, wait: bool, feedback: bool = False) -> MoveJob:
    """A move job for checked ``positions`` (request frame), its times set from now."""
    mapping = book.mapping
    servo_deg = [mapping.to_servo_deg(name, p) if name is not None and mapping is not None else p
                 for (_, name), p in zip(targets, positions)]
    now = time.monotonic()
    timeout = timeout_s if timeout_s > 0 and math.isfinite(timeout_s) else DEFAULT_TIMEOUT_S
    move = Move(targets, servo_deg, tolerance_deg if tolerance_deg > 0 else DEFAULT_TOLERANCE_DEG, now + timeout)
    grace_until = now + book.grace_s
    # answered by then at the latest: the deadline (with wait) plus a few loops, else the loop's time
    slack = max(3 * book.period_s, 0.3)
    answer_by = move.deadline + slack if wait else now + max(book.grace_s, 0.0) + LOOP_TIMEOUT_S
    return MoveJob(move, velocity, wait, grace_until, answer_by, feedback)
