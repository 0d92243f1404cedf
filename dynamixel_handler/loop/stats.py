"""The loop's statistics line and its rate check, on the loop thread. ROS-free.

The line has the original handler's text and levels: ``time=%2.2fms/loop(%2.2fms/read),
success=%3.0f%%(full=%3.0f%%)``, ERROR when fewer than 80 % of the transactions got every reply,
WARN when fewer than 99 % got any, INFO otherwise. It comes every ``verbose_ratio`` loops, but
at most once every ``STATS_MIN_S`` (a fast loop: it then covers more loops), and at least every
``STATS_MAX_S`` seconds whatever ``verbose_ratio`` is (also 0) and however slow the loop is.
While the device is gone it says so, and since when, instead of a success rate.

Every ``RATE_WINDOW_S`` the loop period is measured: the bus watchdog time follows what two
windows in a row show (``Watchdog.note_loop_period``), and a loop that cannot hold ``loop_rate`` is
reported once, with the rate it does reach and the bus time a loop takes.

Both lines go to ``emit(kind, level, text)``: kind ``"statistics"`` or ``"rate"``, level one of
``logging``'s (INFO, WARNING, ERROR).
"""
from __future__ import annotations

import logging
import time
from typing import Callable, Protocol, Sized

from ..bus.api import StatsWire

#: longest time between two statistics lines [s]
STATS_MAX_S = 10.0
#: shortest time between two statistics lines [s]
STATS_MIN_S = 1.0
#: the loop rate is measured over windows of this length [s]
RATE_WINDOW_S = 2.0
#: ... and at least this many loops
RATE_WINDOW_LOOPS = 3
#: a loop rate below this share of loop_rate is reported
RATE_TOLERANCE = 0.9

#: (kind, level, text): where the statistics line and the rate warning go
Emit = Callable[[str, int, str], None]


class DeviceState(Protocol):
    """Whether the device is gone, and since when (``Recovery``)."""

    @property
    def device_lost(self) -> bool: ...
    @property
    def device_lost_since(self) -> float | None: ...


class PeriodSink(Protocol):
    """Who keeps the measured loop period (``Watchdog``: the bus watchdog time follows it)."""

    def note_loop_period(self, seconds: float) -> None: ...


class WireEstimate(Protocol):
    """The wire time of a loop's reads (``Reads``)."""

    def wire_s_per_loop(self) -> float: ...


class StatsCore(Protocol):
    """What the statistics need of the ``Handler``: its table and three of its parts."""

    @property
    def table(self) -> Sized: ...
    @property
    def recovery(self) -> DeviceState: ...
    @property
    def watchdog(self) -> PeriodSink: ...
    @property
    def reads(self) -> WireEstimate: ...


class Finished(Protocol):
    """What the statistics need of a finished loop (``StepReport``)."""

    @property
    def reads(self) -> Sized: ...
    @property
    def read_s(self) -> float: ...


class LoopStats:
    def __init__(self, handler: StatsCore, wire: StatsWire, emit: Emit, loop_rate: float, verbose_ratio: int) -> None:
        self.h = handler
        self.wire = wire
        self.emit = emit
        self.loop_rate = float(loop_rate)
        self.verbose_ratio = int(verbose_ratio)
        now = time.monotonic()
        self._start, self._loops, self._read, self._reads = now, 0, 0.0, 0
        self._before = wire.stats.copy()
        self._rate_start, self._rate_loops, self._rate_read, self._rate_reads = now, 0, 0.0, 0
        self.slow_warned = False
        self._last_period: float | None = None  # the window before: one slow window alone is not trusted

    def tick(self, finished: Finished | None) -> None:
        """After each loop (``finished``: the loop completed in this pass, if any)."""
        self._loops += 1
        self._rate_loops += 1
        if finished is not None and finished.reads:
            self._read += finished.read_s
            self._reads += 1
            self._rate_read += finished.read_s
            self._rate_reads += 1
        now = time.monotonic()
        if now - self._rate_start >= RATE_WINDOW_S and self._rate_loops >= RATE_WINDOW_LOOPS:
            self._check_rate(now)
        since = now - self._start
        if (self.verbose_ratio and self._loops >= self.verbose_ratio and since >= STATS_MIN_S) or since >= STATS_MAX_S:
            self._line(now)

    def _check_rate(self, now: float) -> None:
        elapsed, loops = now - self._rate_start, self._rate_loops
        read_s = self._rate_read / max(1, self._rate_reads)
        self._rate_start, self._rate_loops, self._rate_read, self._rate_reads = now, 0, 0.0, 0
        if self.h.recovery.device_lost:
            return
        measured, last = elapsed / loops, self._last_period
        self._last_period = measured
        if last is None:  # the first window holds the start (watchdogs armed, first commands)
            return
        period = min(measured, last)  # what two windows in a row show
        self.h.watchdog.note_loop_period(period)
        rate = 1.0 / period
        if rate < RATE_TOLERANCE * self.loop_rate and not self.slow_warned:
            self.slow_warned = True
            wire_s = self.h.reads.wire_s_per_loop()
            self.emit("rate", logging.WARNING,
                      f"loop_rate {self.loop_rate:g} Hz cannot be held: {rate:.1f} loops/s ({1000 * period:.1f} ms a "
                      f"loop; the reads of {len(self.h.table)} servo(s) at {self.wire.baudrate} bps take "
                      f"{1000 * wire_s:.1f} ms of wire a loop, the reads measured {1000 * read_s:.1f} ms); lower "
                      "loop_rate, raise baudrate, or read less (pub_ratio/*); the bus watchdog follows the loop")

    def _line(self, now: float) -> None:
        loops = max(1, self._loops)
        head = (f"time={1000 * (now - self._start) / loops:2.2f}ms/loop"
                f"({1000 * self._read / max(1, self._reads):2.2f}ms/read), ")
        since = self.h.recovery.device_lost_since
        if self.h.recovery.device_lost and since is not None:
            self.emit("statistics", logging.ERROR,
                      head + f"device {self.wire.device} gone since "
                      f"{time.strftime('%H:%M:%S', time.localtime(since))} ({time.time() - since:.0f} s ago): "
                      "nothing read, reconnecting")
        else:
            delta = self.wire.stats.delta(self._before)
            partial, full = 100 * delta.success_rate, 100 * delta.full_success_rate
            line = head + f"success={partial:3.0f}%(full={full:3.0f}%)"
            level = logging.ERROR if full < 80 else logging.WARNING if partial < 99 else logging.INFO
            self.emit("statistics", level, line)
        self._start, self._loops, self._read, self._reads = now, 0, 0.0, 0
        self._before = self.wire.stats.copy()
