"""The loop scheduler: drives a ``Handler`` at ``loop_rate`` on a thread of its own. ROS-free.

Whoever owns the runner (the ROS node, a plain Python script) wires it with ``Hooks``: where
commands come from (``take_commands``, ``wait_commands``), what to do with a finished loop's states
(``states_ready``), with an external-port reading, with the statistics line and the "loop_rate
cannot be held" warning (``report``) and with a loop that gave up (``gave_up``). Every hook has a
default, so ``Runner(handler, bus, 100).run(loops=500)`` drives a bus with nothing else.

With time to spare in a period, each loop runs its phases back to back, hands its states over and
sleeps. Commands that arrived while its read was on the wire are written as soon as the replies
are in (before the bookkeeping); the sleep is cut short by the first command that arrives (applied
at once, ``Handler.apply_now``), later ones in the same period wait for the next loop, so commands
add at most two sync writes per period to the bus. Running flat out (a loop takes longer than a period),
each loop's last read is left on the wire while the previous loop is completed and handed over;
shortly before its replies are due the next commands are taken, and as soon as the replies are in
the goals go out with the next reads right behind them: the bus then waits on the wire, hardly
on Python. A loop step that raises is logged and skipped; ``MAX_LOOP_FAILURES`` in a row end the
loop (``failed``; the owner then makes the servos safe).
"""
from __future__ import annotations

import logging
import os
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Callable, Protocol

from ..bus.api import StatsWire
from ..core.handler import StepReport
from ..external_ports import ExternalPorts, PortReading
from .stats import LoopStats, StatsCore
from .timing import set_timer_slack

#: consecutive failed loop steps after which the loop gives up
MAX_LOOP_FAILURES = 50
#: running flat out, the next commands are taken this long (plus 1.5 x the time that takes) before
#: the replies of the read on the wire are due, at most MAX_EARLY_S before [s]
EARLY_MARGIN_S = 0.0002
MAX_EARLY_S = 0.002
#: between loops, a command is written at once unless the next loop starts within this time [s]
EARLY_WRITE_MIN_S = 0.0005
#: longest wait for a command before the loop looks at its stop flag again [s]
STOP_CHECK_S = 0.05


class Log(Protocol):
    """A ``logging.Logger`` or an rclpy node's logger: one message a call."""

    def debug(self, msg: str, /) -> object: ...
    def info(self, msg: str, /) -> object: ...
    def warning(self, msg: str, /) -> object: ...
    def error(self, msg: str, /) -> object: ...
    def fatal(self, msg: str, /) -> object: ...


class Phases(Protocol):
    """The loop step in phases (``core.step.Step``): what the runner drives directly."""

    @property
    def loop_count(self) -> int: ...
    @property
    def reply_eta(self) -> float | None: ...
    def begin_step(self) -> StepReport: ...
    def encode_writes(self) -> None: ...
    def await_replies(self, report: StepReport) -> None: ...
    def prepare(self, report: StepReport) -> None: ...
    def send_writes(self, report: StepReport) -> None: ...
    def send_reads(self, report: StepReport) -> None: ...
    def complete_step(self, report: StepReport) -> None: ...
    def finish_step(self, report: StepReport) -> None: ...
    def apply_now(self) -> None: ...


class LoopCore(StatsCore, Protocol):
    """What the runner needs of the ``Handler``: what the statistics need, and its step in phases
    (``steps``), which the runner drives itself."""

    @property
    def steps(self) -> Phases: ...


def log_exception(log: Log, what: str, exc: BaseException, fatal: bool = False) -> None:
    """One ERROR (or FATAL) line naming the exception and where it was raised; the traceback
    follows at DEBUG level, one log line per line, so every line carries severity and logger name."""
    frames = traceback.extract_tb(exc.__traceback__)
    where = f" (at {os.path.basename(frames[-1].filename)}:{frames[-1].lineno} in {frames[-1].name})" if frames else ""
    if fatal:  # one call site per severity (an rclpy logger keeps a call site's)
        log.fatal(f"{what}: {type(exc).__name__}: {exc}{where}")
    else:
        log.error(f"{what}: {type(exc).__name__}: {exc}{where}")
    for block in traceback.format_exception(type(exc), exc, exc.__traceback__, limit=6):
        for line in block.rstrip().splitlines():
            log.debug(f"{what}: {line}")


def _no_commands() -> int:
    return 0


def _ignore(_: object) -> None:
    return None


def _nothing() -> None:
    return None


@dataclass
class Hooks:
    """What the runner calls; all on the loop thread."""

    #: at the start of each loop step (an exception fails the step, as any other in it)
    before_step: Callable[[], None] = _nothing
    #: take every waiting command and hand it to the ``Commander``; the number taken
    take_commands: Callable[[], int] = _no_commands
    #: block until a command waits or the time (s) passes; True if one waits. None: just sleep
    wait_commands: Callable[[float], bool] | None = None
    #: a loop's reads are stored in the servo table: its states can be published
    states_ready: Callable[[StepReport], None] = _ignore
    #: what the external ports read this loop (``option/external_port.*``)
    external_read: Callable[[PortReading], None] = _ignore
    #: (kind, level, text): the statistics line ("statistics") and the rate warning ("rate");
    #: None: the runner's logger at that level
    report: Callable[[str, int, str], None] | None = None
    #: the loop gave up after MAX_LOOP_FAILURES failed steps in a row (it has stopped)
    gave_up: Callable[[], None] = _nothing


class Runner:
    """Runs ``handler``'s loop at ``loop_rate``: ``start()``/``stop()`` on a thread of its own, or
    ``run(loops)`` on the caller's thread."""

    def __init__(self, handler: LoopCore, wire: StatsWire, loop_rate: float, verbose_ratio: int = 0,
                 log: Log | None = None, hooks: Hooks | None = None, external: ExternalPorts | None = None) -> None:
        self.h = handler
        self.s: Phases = handler.steps
        self.wire = wire
        self.loop_rate = float(loop_rate)
        self.period = 1.0 / self.loop_rate
        self.verbose_ratio = verbose_ratio
        self.log: Log = log if log is not None else logging.getLogger("dynamixel_handler")
        self.hooks = hooks if hooks is not None else Hooks()
        self.external = external
        self.failed = False
        self.passes = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._prev: StepReport | None = None  # a loop whose last read is still on the wire
        self._next_t = 0.0
        self._begin_s = 0.0  # how long taking commands and beginning a step takes (average)
        self._failures = 0
        self._finished: StepReport | None = None

    # ------------------------------------------------------------------ owner's side
    def start(self) -> None:
        """Run the loop on a thread of its own (``dynamixel_loop``)."""
        self._stop.clear()
        self._thread = threading.Thread(target=self.run, name="dynamixel_loop", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop and wait for its thread; nothing is left on the wire."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def run(self, loops: int | None = None) -> None:
        """The loop, on this thread, until ``stop()``, ``loops`` passes, or it gives up."""
        if set_timer_slack() is None:  # wake-ups on time, not up to 50 µs late (timing.py)
            self.log.debug("loop thread: timer slack left at the system default")
        stats = LoopStats(self.h, self.wire, self._emit, self.loop_rate, self.verbose_ratio)
        self._next_t = time.monotonic()
        self._prev, self._failures, self._begin_s = None, 0, 0.0
        try:
            while not self._stop.is_set() and (loops is None or self.passes < loops):
                self._pass()
                if self.failed:
                    return
                stats.tick(self._finished)
                self._pace()
        finally:
            self._drain()

    # ------------------------------------------------------------------ one pass
    def _pass(self) -> None:
        self.passes += 1
        self._finished = None
        try:
            self._step()
            self._failures = 0
        except Exception as exc:  # keep the loop alive; the context says where it broke
            self._failures += 1
            self._prev = None
            self._next_t += self.period
            log_exception(self.log, f"loop {self.s.loop_count}", exc)
            if self._failures >= MAX_LOOP_FAILURES:
                self.log.fatal(f"the loop failed {self._failures} times in a row: shutting down safely")
                self.failed = True
                self._stop.set()
                self.hooks.gave_up()

    def _step(self) -> None:
        h, prev = self.s, self._prev
        self.hooks.before_step()
        t0 = time.monotonic()
        self.hooks.take_commands()
        report = h.begin_step()
        if prev is not None:
            h.encode_writes()  # the goal packets ready before the line is free
        self._begin_s += 0.2 * (time.monotonic() - t0 - self._begin_s)
        if prev is not None:
            h.await_replies(prev)
            if self.hooks.take_commands():  # commands that came while the replies were due
                h.prepare(report)
        h.send_writes(report)  # the goals first, the reads right behind them:
        reading = self.external.step() if self.external is not None else None
        h.send_reads(report)   # the wire never waits for the bookkeeping below
        if prev is not None:
            self._prev = None
            self._finished = prev
            h.complete_step(prev)
            self._end(prev)
        self._prev = report
        if reading is not None:
            self.hooks.external_read(reading)
        self._next_t += self.period
        # time to spare, or late by less than a period (made up by the loops after it): this loop
        # ends now; only a loop that keeps taking longer than a period runs flat out
        if self._next_t + self.period > time.monotonic() or h.reply_eta is None:
            self._prev = None
            self._finished = report
            self._write_arrived_during(report)
            self._end(report)

    def _write_arrived_during(self, report: StepReport) -> None:
        """Commands that came while this loop's read was on the wire go out as soon as its replies
        are in, before the loop's bookkeeping; the first command after them still goes out at once."""
        if self.hooks.wait_commands is None or self.s.reply_eta is None:
            return
        self.s.await_replies(report)
        if self.hooks.take_commands():
            self.s.apply_now()

    def _end(self, report: StepReport) -> None:
        """Store and log what a loop read, then hand it to the owner."""
        self.s.finish_step(report)
        self.hooks.states_ready(report)

    # ------------------------------------------------------------------ pacing
    def _pace(self) -> None:
        now = time.monotonic()
        if self._prev is None:
            if self._next_t > now:
                self._sleep_until(self._next_t)
            else:
                # overran: the next loop starts now; up to one period late is made up by the loops
                # after it (so scheduling jitter under load does not lower the rate), more is not
                # caught up
                self._next_t = max(self._next_t, now - self.period)
            return
        self._next_t = now
        eta = self.s.reply_eta
        if eta is not None:  # take the next commands as late as the replies allow
            wake = eta - min(MAX_EARLY_S, 1.5 * self._begin_s + EARLY_MARGIN_S)
            if wake > now:
                self._stop.wait(wake - now)

    def _sleep_until(self, t: float) -> None:
        """Sleep until the next loop; the first command that arrives meanwhile is applied at once."""
        wait = self.hooks.wait_commands
        while wait is not None and not self._stop.is_set():
            remaining = t - time.monotonic()
            if remaining <= EARLY_WRITE_MIN_S:
                break
            if wait(min(remaining, STOP_CHECK_S)) and self.hooks.take_commands():
                try:
                    self.s.apply_now()
                except Exception as exc:  # as in the loop: logged, never fatal
                    log_exception(self.log, "applying a command between loops", exc)
                break
        remaining = t - time.monotonic()
        if remaining > 0:
            self._stop.wait(remaining)

    def _drain(self) -> None:
        """Nothing stays on the wire once the loop has stopped."""
        prev, self._prev = self._prev, None
        if prev is None:
            return
        try:
            self.s.complete_step(prev)
        except Exception as exc:
            self.log.warning(f"last read: {type(exc).__name__}: {exc}")

    def _emit(self, kind: str, level: int, text: str) -> None:
        if self.hooks.report is not None:
            self.hooks.report(kind, level, text)
            return
        if level >= logging.ERROR:  # one call site per severity (an rclpy logger keeps a call site's)
            self.log.error(text)
        elif level >= logging.WARNING:
            self.log.warning(text)
        else:
            self.log.info(text)
