"""The bus watchdog: its time, from the loop period; arming, clearing, trips."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..groups import GROUP_RATIO_PARAM, PRESENT
from .log_limits import LogLimits
from .read_plan import ReadPlan
from .servo_io import ServoIO

#: bus watchdog register value (signed) of a servo whose watchdog has tripped
WATCHDOG_TRIPPED = -1
#: operating modes in which the bus watchdog is armed: a servo in a position mode holds its goal
#: by itself, and a watchdog trip in a position mode with a homing offset moves the shaft by the
#: offset (a firmware fault the original handler works around the same way)
WATCHDOG_MODES = frozenset({"velocity", "current", "pwm"})
#: longest bus watchdog time the register holds (127 x 20 ms)
WATCHDOG_MAX_MS = 2540.0


class Watchdog(ServoIO, ReadPlan, LogLimits):
    """The bus watchdog of every servo: only in velocity, current and PWM modes (or as a command set it)."""

    #: (ID, pulses asked for) whose raise to what the loop needs was warned about
    _raised_warned: set[tuple[int, int]] | None = None

    def _needed_ms(self) -> float | None:
        """The least bus watchdog time a healthy loop keeps: three times the longest gap between
        two reads of a servo [ms]; None when nothing is read after start-up (a watchdog would stop
        every servo)."""
        cfg = self.config
        ratios = [cfg.present_ratio(k) for k in PRESENT] + [cfg[p] for p in GROUP_RATIO_PARAM.values()]
        every = min((r for r in ratios if r > 0), default=0)
        if every == 0:
            return None
        return 3000.0 * every * max(1.0 / float(cfg["loop_rate"]), self.loop_period_s)

    def watchdog_pulses(self) -> int:
        """Bus watchdog register value (20 ms units, 0 = off): default/bus_watchdog, but at least three
        times the longest gap between two reads of a servo, so a healthy loop never trips it."""
        cfg = self.config
        if not cfg["term/servo_auto_stop"] or cfg["default/bus_watchdog"] <= 0:
            return 0
        needed = self._needed_ms()
        if needed is None:
            return 0
        ms = max(cfg["default/bus_watchdog"], needed)
        if ms > WATCHDOG_MAX_MS and not self._watchdog_warned:
            self._watchdog_warned = True
            self.log.warning(f"bus watchdog: a servo is addressed every {needed / 3:.0f} ms, so it needs "
                             f"{ms:.0f} ms, but the register holds at most {WATCHDOG_MAX_MS:g} ms: set to that, a servo "
                             "may stop between two loops (lower the bus time per loop: fewer reads, higher baudrate)")
        return int(min(127, max(1, round(ms / 20.0))))

    def note_loop_period(self, seconds: float) -> None:
        """The loop period measured (or estimated): when it moves the bus watchdog time (longer by a
        quarter, or shorter by half), the servos that have the automatic one get it anew."""
        old = self.loop_period_s
        if old and old / 2 < seconds < old * 1.25:
            return
        before = {i: self.watchdog_for(i) for i in self.table.ids}
        self.loop_period_s = seconds
        self._to_arm.update(i for i, pulses in before.items() if self.watchdog_for(i) != pulses)

    def estimate_loop_s(self) -> float:
        """Wire time of the reads over every handled servo (instruction and replies at the baud
        rate, plus the adapter's latency each way) per loop, on average over the loops between two
        reads of the most often read items: the loop period before one is measured."""
        if not len(self.table) or not self.bus.baudrate:
            return 0.0
        cfg = self.config
        ratios = [cfg.present_ratio(k) for k in PRESENT] + [cfg[p] for p in GROUP_RATIO_PARAM.values()]
        every = min((r for r in ratios if r > 0), default=0)
        items, _, _ = self.due_items(every)  # the loop that reads the most often read items
        if not every or not items:
            return 0.0
        live = np.ones(len(self.table), dtype=bool)
        byte_s = 10.0 / self.bus.baudrate
        latency_s = 2 * self.bus.latency_timer_ms / 1000.0
        total = 0.0
        for read in self._plan(tuple(sorted(set(items))), live):
            n = len(read.ids)
            total += (14 + n + n * (11 + read.length)) * byte_s + latency_s
        return total / every  # per loop, on average

    def watchdog_for(self, dxl_id: int) -> int:
        """The bus watchdog this servo should have [20 ms pulses, 0 = off]: the value a command
        set for it (extra bus_watchdog_ms), else the automatic one (``watchdog_pulses``) in
        velocity, current and PWM modes, else off. A time a command set that the loop cannot keep
        (shorter than three gaps between two reads of the servo) is raised to what it needs."""
        if dxl_id in self.watchdog_user:
            asked = self.watchdog_user[dxl_id]
            needed = self._needed_ms()
            if asked <= 0 or needed is None:
                return asked
            return max(asked, min(127, int(-(-needed // 20))))
        return self.watchdog_pulses() if self.mode(dxl_id) in WATCHDOG_MODES else 0

    def _warn_raised(self, dxl_id: int, pulses: int) -> None:
        """One warning when a watchdog time a command set is raised (per servo and value asked for)."""
        asked = self.watchdog_user.get(dxl_id, 0)
        if not 0 < asked < pulses:
            return
        if self._raised_warned is None:
            self._raised_warned = set()
        if (dxl_id, asked) in self._raised_warned:
            return
        self._raised_warned.add((dxl_id, asked))
        ms = self.table.model(dxl_id).bus_watchdog_ms_per_pulse
        gap = (self._needed_ms() or 0.0) / 3
        self.log.warning(f"ID {dxl_id}: bus_watchdog_ms {asked * ms:g} is shorter than the loop can keep (a servo is "
                         f"read every {gap:.0f} ms): raised to {pulses * ms:g} ms (three such gaps), so a healthy loop "
                         "never trips it")

    def arm_watchdog(self, dxl_id: int) -> None:
        """So that a crashed or killed node still stops its servos: the servo stops by itself when
        no instruction has reached it for the watchdog time (X and P; the old Pro has none). Also
        clears a tripped watchdog (a tripped servo refuses goals), and switches it off where the
        servo's mode needs none."""
        if not self.table.model(dxl_id).has("bus_watchdog"):
            return
        pulses = self.watchdog_for(dxl_id)
        self._warn_raised(dxl_id, pulses)
        if self.table.value("bus_watchdog", dxl_id) != 0:
            self.write_item(dxl_id, "bus_watchdog", 0)  # first 0: clears a trip, allows a new value
        if pulses:
            self.write_item(dxl_id, "bus_watchdog", pulses)

    def arm_after_ops(self, dxl_id: int) -> None:
        """After a mode change: a mode that needs no watchdog gets it off at once; one that needs
        it is armed at the start of the next step, once the operations running now are done
        (armed servo by servo inside a burst of mode changes on a slow bus, the first ones would
        trip before the last ones are changed)."""
        if self.watchdog_for(dxl_id):
            self._to_arm.add(dxl_id)
        else:
            self.arm_watchdog(dxl_id)

    def clear_tripped(self, ids: Sequence[int]) -> None:
        """Before goals go to these servos: a bus watchdog known to have tripped is cleared and
        armed again, or the servo would refuse the goals."""
        table = self.table
        known, values = table.known("bus_watchdog"), table.pulses("bus_watchdog")
        for dxl_id in ids:
            pos = table.index.get(dxl_id)
            if pos is not None and known[pos] and values[pos] < 0:
                self.watchdog_trips += 1
                self.log.warning(f"ID {dxl_id}: bus watchdog had tripped: cleared and armed again before the new goal")
                self.arm_watchdog(dxl_id)

    def check_watchdogs(self) -> None:
        """Clear and re-arm watchdogs that tripped (the loop stalled longer than the watchdog
        time), whoever armed them: a tripped servo refuses goals until then."""
        for pos, dxl_id in enumerate(list(self.table.ids)):
            if self.table.known("bus_watchdog")[pos] and self.table.pulses("bus_watchdog")[pos] <= WATCHDOG_TRIPPED:
                self.watchdog_trips += 1
                pulses = self.watchdog_for(dxl_id)
                again = (f"watchdog re-armed ({self.table.model(dxl_id).bus_watchdog_ms_per_pulse * pulses:g} ms)"
                         if pulses else "watchdog cleared (off)")
                self.log.warning(f"ID {dxl_id}: bus watchdog tripped (no instruction within its time): "
                                 f"servo stopped, {again}")
                self.arm_watchdog(dxl_id)
