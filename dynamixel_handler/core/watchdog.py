"""The bus watchdog: its time, from the loop period; arming, clearing, trips."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from ..servo.table import ServoTable
from .group_io import GroupIO
from .servo_io import Log, ServoIO

#: bus watchdog register value (signed) of a servo whose watchdog has tripped
WATCHDOG_TRIPPED = -1
#: operating modes in which the bus watchdog is armed: a servo in a position mode holds its goal
#: by itself, and a watchdog trip in a position mode with a homing offset moves the shaft by the
#: offset (a firmware fault the original handler works around the same way)
WATCHDOG_MODES = frozenset({"velocity", "current", "pwm"})
#: longest bus watchdog time the register holds (127 x 20 ms)
WATCHDOG_MAX_MS = 2540.0


@dataclass(frozen=True)
class WatchdogSettings:
    loop_rate: float          # loop_rate [Hz]
    every: int                # the smallest pub ratio above 0 (0: nothing is read after start-up)
    bus_watchdog_ms: float    # default/bus_watchdog [ms] (0 or less: off)
    auto_stop: bool           # term/servo_auto_stop (off: no automatic watchdog)


class Watchdog:
    """The bus watchdog of every servo: only in velocity, current and PWM modes (or as a command
    set it). ``tripped_once`` False: every goal command looks for tripped watchdogs servo by servo
    (for tests and comparisons), not once per new read of the watchdog values."""

    def __init__(self, table: ServoTable, log: Log, io: ServoIO, group: GroupIO, settings: WatchdogSettings,
                 tripped_once: bool = True) -> None:
        self.table = table
        self.log = log
        self.io = io
        self.group = group
        self.settings = settings
        self.tripped_once = tripped_once
        # the loop period the bus watchdog time derives from: the longer of 1 / loop_rate and the
        # one measured (or, before the first loops, estimated from the wire time of a loop's reads)
        self.loop_period_s = 0.0
        self.trips = 0
        self.user: dict[int, int] = {}  # ID -> bus watchdog pulses a command asked for
        self.to_arm: set[int] = set()  # servos whose bus watchdog is armed at the next step
        self.check_due = False  # bus watchdogs were read: clear the tripped ones at the next step
        self._warned = False
        #: (ID, pulses asked for) whose raise to what the loop needs was warned about
        self._raised_warned: set[tuple[int, int]] = set()
        #: the bus watchdog arrays last looked at and whether one of them shows a trip
        self._tripped_seen: tuple[object, object, bool] = (None, None, True)

    def _needed_ms(self) -> float | None:
        """The least bus watchdog time a healthy loop keeps: three times the longest gap between
        two reads of a servo [ms]; None when nothing is read after start-up (a watchdog would stop
        every servo)."""
        every = self.settings.every
        if every == 0:
            return None
        return 3000.0 * every * max(1.0 / float(self.settings.loop_rate), self.loop_period_s)

    def watchdog_pulses(self) -> int:
        """Bus watchdog register value (20 ms units, 0 = off): default/bus_watchdog, but at least three
        times the longest gap between two reads of a servo, so a healthy loop never trips it."""
        settings = self.settings
        if not settings.auto_stop or settings.bus_watchdog_ms <= 0:
            return 0
        needed = self._needed_ms()
        if needed is None:
            return 0
        ms = max(settings.bus_watchdog_ms, needed)
        if ms > WATCHDOG_MAX_MS and not self._warned:
            self._warned = True
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
        self.to_arm.update(i for i, pulses in before.items() if self.watchdog_for(i) != pulses)

    def watchdog_for(self, dxl_id: int) -> int:
        """The bus watchdog this servo should have [20 ms pulses, 0 = off]: the value a command
        set for it (extra bus_watchdog_ms), else the automatic one (``watchdog_pulses``) in
        velocity, current and PWM modes, else off. A time a command set that the loop cannot keep
        (shorter than three gaps between two reads of the servo) is raised to what it needs."""
        if dxl_id in self.user:
            asked = self.user[dxl_id]
            needed = self._needed_ms()
            if asked <= 0 or needed is None:
                return asked
            return max(asked, min(127, int(-(-needed // 20))))
        return self.watchdog_pulses() if self.io.mode(dxl_id) in WATCHDOG_MODES else 0

    def _warn_raised(self, dxl_id: int, pulses: int) -> None:
        """One warning when a watchdog time a command set is raised (per servo and value asked for)."""
        asked = self.user.get(dxl_id, 0)
        if not 0 < asked < pulses:
            return
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
            self.io.write_item(dxl_id, "bus_watchdog", 0)  # first 0: clears a trip, allows a new value
        if pulses:
            self.io.write_item(dxl_id, "bus_watchdog", pulses)

    def request_arm(self, dxl_id: int) -> None:
        """Arm the servo's bus watchdog at the start of the next step (its set-up done, or back
        after a silence in which it may have tripped)."""
        self.to_arm.add(dxl_id)

    def check_later(self) -> None:
        """Bus watchdogs were read: the tripped ones are cleared at the next step."""
        self.check_due = True

    def arm_after_ops(self, dxl_id: int) -> None:
        """After a mode change: a mode that needs no watchdog gets it off at once; one that needs
        it is armed at the start of the next step, once the operations running now are done
        (armed servo by servo inside a burst of mode changes on a slow bus, the first ones would
        trip before the last ones are changed)."""
        if self.watchdog_for(dxl_id):
            self.to_arm.add(dxl_id)
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
                self.trips += 1
                self.log.warning(f"ID {dxl_id}: bus watchdog had tripped: cleared and armed again before the new goal")
                self.arm_watchdog(dxl_id)

    def check_watchdogs(self) -> None:
        """Clear and re-arm watchdogs that tripped (the loop stalled longer than the watchdog
        time), whoever armed them: a tripped servo refuses goals until then."""
        for pos, dxl_id in enumerate(list(self.table.ids)):
            if self.table.known("bus_watchdog")[pos] and self.table.pulses("bus_watchdog")[pos] <= WATCHDOG_TRIPPED:
                self.trips += 1
                pulses = self.watchdog_for(dxl_id)
                again = (f"watchdog re-armed ({self.table.model(dxl_id).bus_watchdog_ms_per_pulse * pulses:g} ms)"
                         if pulses else "watchdog cleared (off)")
                self.log.warning(f"ID {dxl_id}: bus watchdog tripped (no instruction within its time): "
                                 f"servo stopped, {again}")
                self.arm_watchdog(dxl_id)

    def arm_waiting(self) -> None:
        """At the start of a step: the servos waiting for their watchdog (``to_arm``) armed, and
        the watchdogs the last reads found tripped cleared and armed again."""
        if self.to_arm:
            self.arm_many(sorted(i for i in self.to_arm if i in self.table))
            self.to_arm.clear()
        if self.check_due:
            self.check_due = False
            self.check_watchdogs()

    def arm_many(self, ids: list[int]) -> None:
        """``arm_watchdog`` for many servos at once: the automatic watchdogs in two sync writes
        (0 first where one is set: clears a trip, allows a new value), so that arming twenty servos
        on a slow bus does not leave the first ones armed unaddressed while the last ones are
        written; a watchdog a command set, servo by servo."""
        auto = [i for i in ids if i not in self.user and self.table.model(i).has("bus_watchdog")]
        for dxl_id in ids:
            if dxl_id in self.user:
                self.arm_watchdog(dxl_id)
        pulses = {i: self.watchdog_for(i) for i in auto}
        self.group.write_group("bus_watchdog", {i: 0 for i in auto if self.table.value("bus_watchdog", i) != 0},
                               "watchdog")
        self.group.write_group("bus_watchdog", {i: p for i, p in pulses.items() if p}, "watchdog")

    def any_tripped(self) -> bool:
        """Whether the table shows any servo's bus watchdog tripped (``clear_tripped`` has work);
        answered once per new read or write of the watchdog values."""
        if not self.tripped_once:
            return True
        values, known = self.table.arrays("bus_watchdog")
        seen = self._tripped_seen
        if values is seen[0] and known is seen[1]:
            return seen[2]
        tripped = values is not None and known is not None and bool((known & (values < 0)).any())
        self._tripped_seen = (values, known, tripped)
        return tripped

    def set_user(self, dxl_id: int, pulses: int) -> None:
        """A bus watchdog the servo keeps whatever its mode (0: off), armed now."""
        self.user[dxl_id] = pulses
        self.arm_watchdog(dxl_id)

    def keep_user(self, dxl_id: int, pulses: int) -> None:
        """A bus watchdog the servo keeps whatever its mode (0: off), armed when the loop arms the
        watchdogs (its start, after a reboot): the ``servos`` block's value."""
        self.user[dxl_id] = pulses

    def user_ids(self) -> set[int]:
        """The servos whose bus watchdog an owner set (a command or the ``servos`` block)."""
        return set(self.user)

    def forget(self, dxl_id: int) -> None:
        """The servo is no longer handled."""
        self.user.pop(dxl_id, None)
