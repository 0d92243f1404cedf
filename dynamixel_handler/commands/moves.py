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

import itertools
import math
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from typing import Callable, ClassVar, Sequence, assert_never, get_args

from ..core.api import ServoAccess
from ..joints import JointMap, LiveJoints
from ..logs import some_ids
from .command_types import MoveRequest, MoveWritten, StartMove, TorqueStep
from .commander import Commander
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
    servo_goals,
    with_notes,
)
from .move_io import MoveIO

__all__ = ["Book", "Job", "MoveJob", "TorqueJob", "CANCELED", "DONE", "ERROR", "PREEMPTED", "REACHED", "TIMED_OUT",
           "MoveError"]

#: how far a written goal may be from the requested one before the answer says so [deg]
GOAL_NOTE_DEG = 0.2
#: how long a job that needs no waiting may take the loop to carry out before it is answered anyway [s]
LOOP_TIMEOUT_S = 5.0
#: least time between two wake-ups of the executor for feedback [s]
FEEDBACK_S = 0.1
#: requests waiting at once; beyond, a request is answered "busy" at once (each waiting request is
#: resumed at every wake-up of the executor: a thousand made each wake-up cost milliseconds)
MAX_JOBS = 64
#: moves whose goals are written in one loop step (more wait for the next)
MAX_STARTS = 16


class Job(ABC):
    """A request the loop thread carries out; ended once (``finish``), the first end wins."""

    _numbers = itertools.count(1)
    #: whether it can move a servo (the E-stop ends such jobs; torque off, a reboot go on)
    moves = True

    def __init__(self, what: str, ids: list[int], answer_by: float) -> None:
        self.seq = next(Job._numbers)  # arrival order (atomic: jobs come from several threads)
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

    @abstractmethod
    def advance(self, book: Book, now: float) -> None:
        """Loop thread, after a step: carry the job on, and set ``outcome`` once it has ended."""

    def overdue(self) -> tuple[int, str]:
        return ERROR, f"the bus loop did not carry out '{self.what}' in time: nothing was written"


class TorqueJob(Job):
    def __init__(self, ids: list[int], enable: bool, answer_by: float) -> None:
        super().__init__(f"torque {'on' if enable else 'off'}", ids, answer_by)
        self.enable = enable
        self.moves = enable
        self.todo = deque(ids)
        self.failed: list[int] = []
        self.why = ""  # why the last failed servo failed
        self.queued = False

    def advance(self, book: Book, now: float) -> None:
        if not self.queued:
            self.queued = True
            book.h.submit(TorqueStep(self, self.what))

    def write(self, book: Book) -> None:
        """Loop thread: the next servos, within half a period (at least one)."""
        self.queued = False
        if not self.claimed and not self._begin(book):
            return
        h = book.h
        end = time.perf_counter() + 0.5 * book.period_s
        while self.todo and not self.finished:
            dxl_id = self.todo.popleft()
            written = h.core.torque_on(dxl_id) if self.enable else h.core.torque_off(dxl_id)
            if not written:
                self.failed.append(dxl_id)
                self.why = written.failure
            if time.perf_counter() > end:
                break
        if self.todo:
            return
        if self.failed:
            book.finish(self, ERROR, f"{self.what} failed on IDs [{listed(self.failed)}]: {self.why}")
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
        self.state = "answers"  # -> "ready" -> "writing" -> "following"
        self.watch = Watch(move)
        self.cancel_requested = False
        self.want_feedback = feedback
        self.feedback: tuple[list[float], list[float]] | None = None  # latest (positions, remaining)
        self.feedback_sent = 0.0  # when feedback last went out (``services``)

    def advance(self, book: Book, now: float) -> None:
        if self.cancel_requested and self.state in ("answers", "ready"):
            book.finish(self, CANCELED, "cancelled before it started: nothing was written")
        elif self.state == "answers":
            table = book.h.table
            silent = [i for i in self.ids if i in table and not table.ping[table.index[i]]]
            if not silent or now >= self.grace_until:
                self.state = "ready"  # the Book starts it (``start_ready``)
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
        if not self.wait:
            return ERROR, "the bus loop did not confirm the goals in time (they may still be written)"
        return TIMED_OUT, with_notes("timed out: the bus loop read no positions in time", self.move)


class Book(MoveIO):
    """The jobs under way (any thread adds; the loop thread advances them after each step)."""

    def __init__(self, handler: ServoAccess, commander: Commander, joints: JointMap | LiveJoints | None,
                 wake: Callable[[], None] = lambda: None) -> None:
        super().__init__(handler, commander, joints)
        self.wake = wake  # called when jobs ended or feedback is due (wakes the executor)
        self.jobs: list[Job] = []
        self.lock = threading.Lock()
        self._last_feedback = 0.0
        self._ended = False  # a job ended since the executor was last woken

    TAKES: ClassVar[tuple[type, ...]] = get_args(MoveRequest)

    def handle(self, request: MoveRequest) -> None:
        """A job's next step, queued by the job itself (loop thread)."""
        match request:
            case TorqueStep(job=job):
                job.write(self)
            case StartMove(job=job):
                self.start(job)
            case MoveWritten(job=job):
                self._written(job)
            case _:
                assert_never(request)

    @property
    def period_s(self) -> float:
        return 1.0 / float(self.h.settings.loop.rate_hz)

    @property
    def grace_s(self) -> float:
        """How long a move waits for servos that missed the last read (a loaded host, a noisy bus)
        before it is refused: SILENT_S, plus the loops until a silent servo is pinged again."""
        figures = self.h.figures()
        return SILENT_S + figures.recheck_loops * max(self.period_s, figures.loop_period_s)

    # ------------------------------------------------------------------ any thread
    def add(self, job: Job) -> None:
        with self.lock:
            if len(self.jobs) >= MAX_JOBS:
                raise MoveError(f"busy: {len(self.jobs)} requests are waiting already: try again later")
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
        self._ended = True  # the executor is woken once at the end of the step (``on_step``)
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
        """Step hook: advance every job; wake the executor once if jobs ended (in this step's
        operations or here), or for feedback every FEEDBACK_S while goals move."""
        now = time.monotonic()
        if self.jobs:
            with self.lock:
                jobs = list(self.jobs)
            jobs = self._unstopped(jobs)  # (finish takes the lock)
            for job in jobs:
                self._advance(job, now)
            self.start_ready([j for j in jobs if isinstance(j, MoveJob) and j.state == "ready" and not j.finished])
            if now - self._last_feedback >= FEEDBACK_S and _feedback_waits(jobs):
                self._last_feedback = now
                self._ended = True
        if self._ended:
            self._ended = False
            self.wake()

    def _unstopped(self, jobs: list[Job]) -> list[Job]:
        """``jobs``, but while the E-stop is engaged those that can move a servo end now (the
        servos hold where they are)."""
        stop = self.h.figures().e_stop
        if stop is None:
            return jobs
        self._end_all(jobs, stop)
        return [j for j in jobs if not j.finished]

    def _end_all(self, jobs: list[Job], why: str) -> None:
        for job in jobs:
            if not job.moves:
                continue  # torque off, a reboot: carried out
            written = "the servos hold where they are" if job.claimed else "nothing was written"
            self.finish(job, ERROR, f"ended: the E-stop was engaged ({why}): {written}")

    def _advance(self, job: Job, now: float) -> None:
        try:
            job.advance(self, now)
        except MoveError as err:
            self.finish(job, ERROR, str(err))
        except Exception as exc:  # a job must never stop the loop
            self.finish(job, ERROR, f"{job.what} failed: {type(exc).__name__}: {exc}")

    def start_ready(self, ready: list[MoveJob]) -> None:
        """Queue the moves whose servos answer, oldest first, MAX_STARTS a step; one whose every
        servo a later ready move names ends PREEMPTED unwritten (a burst costs one write)."""
        covered: set[int] = set()
        keep = []
        for job in sorted(ready, key=lambda j: j.seq, reverse=True):
            if covered.issuperset(job.ids):
                self.finish(job, PREEMPTED, f"preempted before it started by a later move of IDs "
                                            f"{some_ids(sorted(job.ids))}; nothing was written")
                continue
            covered.update(job.ids)
            keep.append(job)
        for job in sorted(keep, key=lambda j: j.seq)[:MAX_STARTS]:
            job.state = "writing"
            self.h.submit(StartMove(job))

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
        self.h.submit(MoveWritten(job))

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

def _feedback_waits(jobs: list[Job]) -> bool:
    return any(isinstance(j, MoveJob) and j.feedback is not None and not j.finished for j in jobs)


def new_move(book: Book, targets: Targets, positions: list[float], velocity: float, tolerance_deg: float,
             timeout_s: float, wait: bool, feedback: bool = False) -> MoveJob:
    """A move job for checked ``positions`` (request frame), its times set from now."""
    servo_deg, notes = servo_goals(book.mapping, targets, positions)
    now = time.monotonic()
    timeout = timeout_s if timeout_s > 0 and math.isfinite(timeout_s) else DEFAULT_TIMEOUT_S
    move = Move(targets, servo_deg, tolerance_deg if tolerance_deg > 0 else DEFAULT_TOLERANCE_DEG, now + timeout,
                notes=notes)
    grace_until = now + book.grace_s
    # answered by then at the latest: the deadline (with wait) plus a few loops, else the loop's time
    slack = max(3 * book.period_s, 0.3)
    answer_by = move.deadline + slack if wait else now + book.grace_s + LOOP_TIMEOUT_S
    return MoveJob(move, velocity, wait, grace_until, answer_by, feedback)
