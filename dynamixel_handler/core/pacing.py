"""Bus time while bus watchdogs are armed: no armed servo goes unaddressed for its watchdog time.

A servo's bus watchdog counts from the last instruction that named it. Every sync read names
every servo it reads, so within a loop a servo goes unaddressed for about one read's wire time;
what can make that longer than the watchdog time is one long read (many servos, a wide span of the
control table, a slow bus) or a long run of one-servo transactions (a burst of mode changes). While
any watchdog is armed, both are kept to a share of the shortest armed watchdog time:

- a read whose wire time would be longer than ``READ_SHARE`` of it is split into narrower spans
  (``ReadPlan._plan``); each still names every servo, so the gap is one span's wire time;
- mode changes stop taking the bus once ``OPS_SHARE`` of it has passed since the last reads went
  out (at least one is made after each read): the rest wait for a loop after the next reads
  (deferred, latest request wins), which address every servo again.

Without an armed watchdog nothing changes. The same check lets a stop drop the mode changes not
yet made (``stopping``).
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..bus import ServoBus
from ..servo.table import ServoTable
from .request_types import Later

#: longest wire time of one sync read, as a share of the shortest armed bus watchdog time
READ_SHARE = 1 / 3
#: longest time a loop's mode changes may hold the bus, as a share of the shortest armed watchdog time
OPS_SHARE = 0.25
#: bytes of a sync read instruction without its ID list, and of one reply without its data
SYNC_READ_BYTES, REPLY_BYTES = 14, 11
#: narrowest span a read is cut to (the largest item); a limit below it cuts nothing
MIN_SPAN = 4


class Pacing:
    """The shortest armed bus watchdog time; the read span and operation time it allows.
    ``interrupted()`` tells that the node is stopping."""

    def __init__(self, bus: ServoBus, table: ServoTable, interrupted: Callable[[], bool]) -> None:
        self.bus = bus
        self.table = table
        self.interrupted = interrupted
        #: (values, known) arrays of Bus Watchdog last looked at and the shortest armed time [s] they give
        self._armed_seen: tuple[object, object, float | None] = (None, None, None)
        #: time.monotonic() when the last reads went out (every servo addressed), and the mode changes made since
        self._ops_since = 0.0
        self._ops_made = 0
        self._dropped: set[int] = set()

    @property
    def dropped_mode_changes(self) -> set[int]:
        """IDs whose mode change was asked for but dropped because the node is stopping."""
        return self._dropped

    def drop_mode_change(self, dxl_id: int) -> None:
        """A mode change asked for while the node stops: not made (the shutdown leaves the servo so)."""
        self._dropped.add(dxl_id)

    def shortest_armed_s(self) -> float | None:
        """The shortest bus watchdog time armed in any servo [s] (as last written or read); None: none is."""
        values, known = self.table.arrays("bus_watchdog")
        seen = self._armed_seen
        if values is seen[0] and known is seen[1]:
            return seen[2]
        shortest: float | None = None
        if values is not None and known is not None:
            armed = np.flatnonzero(known & (values > 0))
            if len(armed):
                models = self.table.models
                shortest = min(int(values[pos]) * models[pos].bus_watchdog_ms_per_pulse for pos in armed) / 1000.0
        self._armed_seen = (values, known, shortest)
        return shortest

    def read_span_limit(self, servos: int) -> int | None:
        """Longest span [bytes] one sync read of ``servos`` servos may cover while watchdogs are
        armed (its wire time and the adapter's latency at most READ_SHARE of the shortest); None:
        no limit (none armed, or no span would fit)."""
        shortest = self.shortest_armed_s()
        baudrate = self.bus.baudrate
        if shortest is None or not baudrate or servos <= 0:
            return None
        budget = READ_SHARE * shortest - 2 * self.bus.latency_timer_ms / 1000.0
        wire_bytes = budget * baudrate / 10.0
        longest = int((wire_bytes - SYNC_READ_BYTES - servos) / servos) - REPLY_BYTES
        # not even one 4-byte item fits (the adapter's latency alone takes the time): cutting
        # would only add reads, each with that latency
        return longest if longest >= MIN_SPAN else None

    def note_reads_sent(self) -> None:
        """A loop's reads went out: every servo has just been addressed."""
        self._ops_since = time.monotonic()
        self._ops_made = 0

    def ops_wait(self) -> Later | None:
        """Why a mode change must not be made now: ``STOPPING`` (the node is stopping: it is
        dropped), ``BUS_TIME`` (the mode changes since the last reads have used their share of the shortest
        armed watchdog time: it waits for a loop after the next reads); None: it may be made now.
        One is always made after each read (and one per watchdog time if nothing is read)."""
        if self.interrupted():
            return Later.STOPPING
        shortest = self.shortest_armed_s()
        if self._ops_made and shortest is not None:
            since = time.monotonic() - self._ops_since
            if OPS_SHARE * shortest < since < shortest:
                return Later.BUS_TIME
        self._ops_made += 1
        return None
