"""Checked requests from commands, applied in the loop thread: goals, a mode change, an error
clear, a watchdog time. The command side (``dynamixel_handler.commands``) checks a message and
calls one of these; each goes one way down to the bus."""
from __future__ import annotations

import logging
import time
from typing import Callable, Mapping

from ..control_table import OPERATING_MODES, Model
from .startup import Startup

Warn = Callable[[str], None]
#: RAM items the firmware resets on a mode change (written back after it)
MODE_RESET_ITEMS = ("goal_pwm", "goal_current", "goal_velocity", "profile_velocity", "profile_acceleration")
#: a mode's own goal: left out when the mode changes (it would mean something else in the new one)
OWN_GOAL = {"pwm": "goal_pwm", "current": "goal_current", "velocity": "goal_velocity"}
#: False: every goal command looks for tripped watchdogs servo by servo (for tests and comparisons)
TRIPPED_ONCE = True


class Requests(Startup):
    """What commands may ask of the core, one method per request."""

    #: why the last ``change_mode`` answered "later" (``defer_mode_change`` acts on it)
    _mode_later: str | None = None

    # ---------------------------------------------------------------- queries
    def handles(self, dxl_id: int) -> bool:
        return dxl_id in self.table

    def model(self, dxl_id: int) -> Model:
        return self.table.model(dxl_id)

    @property
    def handled_ids(self) -> list[int]:
        return list(self.table.ids)

    @property
    def last_failure(self) -> str:
        """Why the last bus transaction failed."""
        return self.bus.last_failure

    def value(self, dxl_id: int, item: str) -> int | None:
        """The item's last known value, read from the servo when none is known."""
        value = self.table.value(item, dxl_id)
        return value if value is not None else self.read_item(dxl_id, item)

    # ---------------------------------------------------------------- goals
    def put_goals(self, writes: Mapping[str, Mapping[int, int]]) -> None:
        """Goal values {item: {ID: pulses}} written with the next sync writes; a tripped bus
        watchdog of those servos is cleared first (a tripped servo refuses goals)."""
        if self._any_tripped():
            self.clear_tripped(sorted({i for values in writes.values() for i in values}))
        self.pending.put_many(writes.items())

    #: the bus watchdog arrays last looked at and whether one of them shows a trip
    _tripped_seen: tuple[object, object, bool] = (None, None, True)

    def _any_tripped(self) -> bool:
        """Whether the table shows any servo's bus watchdog tripped (``clear_tripped`` has work);
        answered once per new read or write of the watchdog values."""
        if not TRIPPED_ONCE:
            return True
        values, known = self.table.arrays("bus_watchdog")
        seen = self._tripped_seen
        if values is seen[0] and known is seen[1]:
            return seen[2]
        tripped = values is not None and known is not None and bool((known & (values < 0)).any())
        self._tripped_seen = (values, known, tripped)
        return tripped

    def set_user_watchdog(self, dxl_id: int, pulses: int) -> None:
        """A bus watchdog the servo keeps whatever its mode (0: off)."""
        self.watchdog_user[dxl_id] = pulses
        self.arm_watchdog(dxl_id)

    # ---------------------------------------------------------------- mode changes
    def mode_change_wait(self, dxl_id: int) -> float:
        """Seconds until mode_change_interval_sec has passed since the servo's last mode change."""
        last = self._last_mode_change.get(dxl_id)
        if last is None:
            return 0.0
        interval = float(self.config["mode_change_interval_sec"])
        return max(0.0, last + interval - time.monotonic())

    def defer_mode_change(self, dxl_id: int, what: str, op: Callable[[], None]) -> None:
        """Run ``op`` for this servo once mode_change_interval_sec allows, or at the next loop when
        this loop's operations have used their bus time (``Pacing.ops_wait``); a later request
        replaces it. While the node stops it is dropped (the servo keeps its mode)."""
        why, self._mode_later = self._mode_later, None
        if why == "stopping":
            self.dropped_mode_changes.add(dxl_id)
            return
        if why == "bus time":
            self.log.debug(f"{what}: waits for the next loop (this loop's mode changes used their bus time)")
            self.deferred[dxl_id] = (time.monotonic(), what, op)
            return
        left = self.mode_change_wait(dxl_id)
        if dxl_id not in self.deferred:
            self.limited(logging.INFO, f"{what}: the last mode change was less than mode_change_interval_sec="
                         f"{self.config['mode_change_interval_sec']:g}s ago: applied in {left:.2f}s", f"defer {dxl_id}")
        self.deferred[dxl_id] = (time.monotonic() + left, what, op)

    def cancel_deferred(self, dxl_id: int) -> None:
        """A later request for the servo wins over a mode change waiting for it."""
        self.deferred.pop(dxl_id, None)

    def change_mode(self, dxl_id: int, mode: str, what: str, warn: Warn) -> str:
        """Torque off -> operating mode -> goals and profiles written back -> torque back as it
        was (safely: goal := present state) -> bus watchdog as the new mode needs. The caller has
        checked that the servo has ``mode``. "done", "failed" (the bus), or "later": the last
        change was less than mode_change_interval_sec ago, or this loop's mode changes used their
        bus time, or the node is stopping (the caller defers the request: ``defer_mode_change``)."""
        self._mode_later = "interval" if self.mode_change_wait(dxl_id) > 0 else self.ops_wait()
        if self._mode_later is not None:
            return "later"
        self._last_mode_change[dxl_id] = time.monotonic()
        model = self.table.model(dxl_id)
        own = OWN_GOAL.get(self.mode(dxl_id) or "")
        keep = {item: self.value(dxl_id, item) for item in MODE_RESET_ITEMS if model.has(item) and item != own}
        torque = self.torque_off_for_eeprom(dxl_id)
        ok = self.write_item(dxl_id, "operating_mode", OPERATING_MODES[mode])
        for item, value in keep.items():
            if value is not None:
                self.write_item(dxl_id, item, value)
        if torque:
            self.torque_on(dxl_id)
        self.arm_after_ops(dxl_id)
        if ok:
            self.limited(logging.INFO, f"ID {dxl_id}: operating mode -> {mode}", f"mode {dxl_id}")
        else:
            warn(f"{what}: ID {dxl_id} mode change to '{mode}' failed: {self.bus.last_failure}")
        return "done" if ok else "failed"

    # ---------------------------------------------------------------- error clear
    def clear_error(self, dxl_id: int, keep_rotation: bool, what: str, warn: Warn) -> bool:
        """Reboot to clear a hardware error (a servo without one is not rebooted); with
        ``keep_rotation`` the multi-turn position survives through the homing offset. Torque comes
        back on if it was on, or if the error's shutdown switched it off (then the error, not the
        user, turned it off). At most once per clear_error_interval_sec per servo."""
        error = self.read_item(dxl_id, "hardware_error_status")
        if error is None:
            warn(f"{what}: ID {dxl_id} did not answer the hardware error read: not rebooted")
            return False
        if error == 0:
            self.log.debug(f"{what}: ID {dxl_id} has no hardware error: nothing to clear (not rebooted)")
            return True
        if not self._clear_allowed(dxl_id, what, warn):
            return False
        torque_was = self.value(dxl_id, "torque_enable")
        shutdown = self.value(dxl_id, "shutdown")
        torque = bool(torque_was) or bool(error & (0xFF if shutdown is None else shutdown))
        before = self.read_item(dxl_id, "present_position")
        offset = self.read_item(dxl_id, "homing_offset")
        if not self.reboot(dxl_id):
            warn(f"{what}: ID {dxl_id} reboot failed: {self.bus.last_failure}")
            return False
        self.read_item(dxl_id, "torque_enable")
        self.read_item(dxl_id, "hardware_error_status")
        if keep_rotation and before is not None and offset is not None:
            self._keep_turns(dxl_id, before, offset)
        if torque:
            self.torque_on(dxl_id)
        self.log.info(f"ID {dxl_id}: hardware error cleared ({'turns kept' if keep_rotation else 'turns reset'})")
        return True

    def _clear_allowed(self, dxl_id: int, what: str, warn: Warn) -> bool:
        now, interval = time.monotonic(), self.config["clear_error_interval_sec"]
        last = self._last_clear.get(dxl_id)
        if last is not None and now - last < interval:
            warn(f"{what}: ID {dxl_id} error clear refused: the last one was {now - last:.2f}s ago "
                 f"(clear_error_interval_sec={interval:g})")
            return False
        self._last_clear[dxl_id] = now
        return True

    def _keep_turns(self, dxl_id: int, before: int, offset: int) -> None:
        """After a reboot the position restarts within one turn: the turns it had go into the
        homing offset, so the multi-turn position is the one before."""
        after = self.read_item(dxl_id, "present_position")
        if after is None:
            return
        per_turn = int(round(360.0 / self.table.model(dxl_id).position_deg_per_pulse))
        turns = int(round((before - after) / per_turn))
        if turns:
            self.write_eeprom(dxl_id, "homing_offset", offset + turns * per_turn)
            self.read_item(dxl_id, "present_position")
