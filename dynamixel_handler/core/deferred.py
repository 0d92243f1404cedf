"""Work that waits: EEPROM writes spared, per-servo operations due later, operations queued by callbacks."""
from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Callable

from .log_limits import LogLimits
from .servo_io import ServoIO

#: least time between two writes of one EEPROM item of one servo [s]; a value asked for sooner is
#: written when the time has passed (the latest one asked for)
EEPROM_WRITE_INTERVAL_S = 1.0


class Deferred(ServoIO, LogLimits):
    """EEPROM coalescing, deferred per-servo operations (mode changes asked for too soon), the operation queue."""

    _membership: dict[int, bool] | None = None  # Startup's: add_id / remove_id asked for in this loop

    if TYPE_CHECKING:
        def _apply_membership(self) -> None: ...  # Startup's

    def write_eeprom(self, dxl_id: int, item: str, pulses: int) -> bool:
        """Write one EEPROM item (see ``write_eeprom_many``)."""
        if not self.table.model(dxl_id).has(item):
            return False
        return self.write_eeprom_many(dxl_id, {item: pulses})

    def write_eeprom_many(self, dxl_id: int, values: dict[str, int]) -> bool:
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
            if self.read_item(dxl_id, item) == pulses:
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
        if not todo:
            return True
        torque = self.torque_off_for_eeprom(dxl_id)
        ok = True
        for item, pulses in todo.items():
            if self.write_item(dxl_id, item, pulses):
                self._eeprom_written[(dxl_id, item)] = time.monotonic()
            else:
                ok = False
                self.log.warning(f"ID {dxl_id}: writing {item}={pulses} failed: {self.bus.last_failure}")
        if torque:
            self.torque_on(dxl_id)
        return ok

    def _run_deferred(self) -> None:
        """EEPROM values and per-servo operations that had to wait, once their time has come."""
        now = time.monotonic()
        if self._eeprom_deferred:
            self._write_due_eeprom(now)
        for dxl_id, (when, what, op) in list(self.deferred.items()):
            if when > now:
                continue
            del self.deferred[dxl_id]
            if dxl_id in self.table:
                self._run_op(what, op)

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

    def _run_op(self, what: str, op: Callable[[], None]) -> None:
        try:
            op()
        except Exception as exc:  # an operation must never stop the loop
            self.log.error(f"{what} failed: {type(exc).__name__}: {exc}")

    def queue(self, what: str, op: Callable[[], None]) -> None:
        """Run ``op`` in the loop thread at the start of the next step (callbacks never touch the bus)."""
        with self._ops_lock:
            self._ops.append((what, op))

    def drop_ops(self) -> int:
        """Forget the queued operations (the loop does not run); how many there were."""
        with self._ops_lock:
            count = len(self._ops)
            self._ops.clear()
        return count

    def _run_ops(self) -> None:
        while True:
            with self._ops_lock:
                if not self._ops:
                    break
                what, op = self._ops.popleft()
            self._run_op(what, op)
        if self._membership:  # add_id / remove_id asked for by these operations: once each
            self._run_op("add_id / remove_id", self._apply_membership)
