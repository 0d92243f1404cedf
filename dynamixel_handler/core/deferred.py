"""Work that waits: EEPROM writes spared, per-servo requests due later (mode changes asked for too soon)."""
from __future__ import annotations

import logging
import time

from ..bus import Failure, Result
from ..servo.table import ServoTable
from .log_limits import LogLimits
from .servo_io import Log, ServoIO

#: least time between two writes of one EEPROM item of one servo [s]; a value asked for sooner is
#: written when the time has passed (the latest one asked for)
EEPROM_WRITE_INTERVAL_S = 1.0


class Deferred:
    """EEPROM coalescing and deferred per-servo requests (mode changes asked for too soon); the
    requests queued by callbacks are the ``Intake``'s."""

    def __init__(self, table: ServoTable, log: Log, io: ServoIO) -> None:
        self.table = table
        self.log = log
        self.io = io
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        # ID -> (monotonic time when due, what, request): per-servo work that must wait (a mode
        # change asked for too soon after the last one); a later request for the servo replaces it
        self.deferred: dict[int, tuple[float, str, object]] = {}
        self._eeprom_written: dict[tuple[int, str], float] = {}  # (ID, item) -> time of the last write
        self._eeprom_deferred: dict[tuple[int, str], int] = {}  # (ID, item) -> value to write when due

    @property
    def waiting(self) -> bool:
        """Whether EEPROM values or per-servo operations wait for their time (``run_deferred``)."""
        return bool(self.deferred or self._eeprom_deferred)

    def forget(self, dxl_id: int) -> None:
        """The servo is no longer handled: nothing waits for it."""
        self.deferred.pop(dxl_id, None)
        for key in [k for k in self._eeprom_deferred if k[0] == dxl_id]:
            del self._eeprom_deferred[key]

    def write_eeprom(self, dxl_id: int, item: str, pulses: int) -> Result[bool]:
        """Write one EEPROM item (see ``write_eeprom_many``)."""
        model = self.table.model(dxl_id)
        if not model.has(item):
            return Result(False, Failure.NO_SUCH_ITEM, f"ID {dxl_id} ({model.name}) has no {item}")
        return self.write_eeprom_many(dxl_id, {item: pulses})

    def write_eeprom_many(self, dxl_id: int, values: dict[str, int]) -> Result[bool]:
        """Write EEPROM items of one servo, sparing its EEPROM: a value equal to the servo's is not
        written; an item written less than EEPROM_WRITE_INTERVAL_S ago is written when that time
        has passed (the latest value asked for). Torque goes off for the write and comes back on
        safely (goals := present state first), so the servo does not jump to an old goal.
        False if a write failed."""
        model = self.table.model(dxl_id)
        now = time.monotonic()
        todo: dict[str, int] = {}
        for item, pulses in values.items():
            if not model.has(item):
                continue
            key = (dxl_id, item)
            if self.io.read_item(dxl_id, item) == pulses:
                self._eeprom_deferred.pop(key, None)  # already so: nothing to write, nothing later
                continue
            last = self._eeprom_written.get(key)
            if last is not None and now - last < EEPROM_WRITE_INTERVAL_S:
                if key not in self._eeprom_deferred:
                    self.limited(logging.INFO, f"ID {dxl_id}: {item} was written {now - last:.2f}s ago: {item}={pulses} "
                                 f"is written {EEPROM_WRITE_INTERVAL_S:g}s after it (EEPROM wear)",
                                 f"eeprom {dxl_id} {item}")
                self._eeprom_deferred[key] = pulses
                continue
            self._eeprom_deferred.pop(key, None)
            todo[item] = pulses
        return self._write_now(dxl_id, todo) if todo else _WRITTEN

    def _ram_copy(self, dxl_id: int, item: str, pulses: int) -> None:
        """The RAM item the servo takes an EEPROM item's value into at power on (XL-320: Torque
        Limit from Max Torque), written too: the new value holds at once, not after a reboot."""
        copy = self.table.model(dxl_id).ram_copies.get(item)
        if copy is not None:
            self.io.write_item(dxl_id, copy, pulses)

    def _write_now(self, dxl_id: int, todo: dict[str, int]) -> Result[bool]:
        """Torque off, the EEPROM items written, torque back on if it was on; the first failure."""
        torque = self.io.torque_off_for_eeprom(dxl_id)
        first_failed: Result[bool] | None = None
        for item, pulses in todo.items():
            written = self.io.write_item(dxl_id, item, pulses)
            if written:
                self._eeprom_written[(dxl_id, item)] = time.monotonic()
                self._ram_copy(dxl_id, item, pulses)
            else:
                first_failed = first_failed or written
                self.log.warning(f"ID {dxl_id}: writing {item}={pulses} failed: {written.why}")
        if torque:
            self.io.torque_on(dxl_id)
        return first_failed or _WRITTEN

    def defer(self, dxl_id: int, when: float, what: str, request: object) -> None:
        """``request`` for the servo again at ``when`` (monotonic); it replaces one waiting."""
        self.deferred[dxl_id] = (when, what, request)

    def cancel(self, dxl_id: int) -> None:
        self.deferred.pop(dxl_id, None)

    def run_deferred(self) -> list[tuple[str, object]]:
        """EEPROM values that had to wait are written once their time has come; the per-servo
        requests whose time has come are given back (what, request), to be run in order."""
        now = time.monotonic()
        if self._eeprom_deferred:
            self._write_due_eeprom(now)
        due = []
        for dxl_id, (when, what, request) in list(self.deferred.items()):
            if when > now:
                continue
            del self.deferred[dxl_id]
            if dxl_id in self.table:
                due.append((what, request))
        return due

    def _write_due_eeprom(self, now: float) -> None:
        due_ids = {i for (i, item) in self._eeprom_deferred
                   if now - self._eeprom_written.get((i, item), 0.0) >= EEPROM_WRITE_INTERVAL_S}
        for dxl_id in sorted(due_ids):
            values = {item: v for (i, item), v in list(self._eeprom_deferred.items()) if i == dxl_id}
            if dxl_id in self.table:
                self.write_eeprom_many(dxl_id, values)
            else:
                for item in values:
                    self._eeprom_deferred.pop((dxl_id, item), None)


_WRITTEN: Result[bool] = Result(True)
