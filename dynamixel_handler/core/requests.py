"""Checked requests from commands, applied in the loop thread: goals, a mode change, an error
clear. The command side (``dynamixel_handler.commands``) checks a message and asks for one of
these through ``calls.CoreCalls``, which hands it here; each goes one way down to the bus and
answers with an ``Answer``."""
from __future__ import annotations

import logging
import time
from typing import Mapping, assert_never

from ..bus import Failure, Result
from ..control_table import Model
from ..control_table.behaviour import ByClearInstruction, ByReboot, ByWritingAgain
from ..servo import error_state
from ..servo.table import PendingWrites, ServoTable
from ..settings import LoopSettings
from .deferred import Deferred
from .kept_settings import KeptSettings
from .log_limits import LogLimits
from .pacing import Pacing
from .reboots import Reboots
from .request_types import DONE, Answer, Later, Outcome, answer, later
from .servo_io import Log, ServoIO
from .turns import give_back_turns
from .watchdog import Watchdog

#: RAM items the firmware resets on a mode change (written back after it)
MODE_RESET_ITEMS = ("goal_pwm", "goal_current", "goal_velocity", "profile_velocity", "profile_acceleration")
#: a mode's own goal: left out when the mode changes (it would mean something else in the new one)
OWN_GOAL = {"pwm": "goal_pwm", "current": "goal_current", "velocity": "goal_velocity"}
#: tries of the mode write within one mode change (a lost reply, a torque off that did not land)
MODE_WRITE_TRIES = 2
#: mode changes of one request before it is given up (the bus silent or refusing for a while)
MODE_ATTEMPTS = 8
#: pause before a mode change that failed is tried again, with the goals that came with it [s]
MODE_RETRY_S = 0.25


class Requests:
    """What commands may ask of the core that takes more than one part. Of the settings:
    ``mode_change_interval_s`` and ``clear_error_interval_s``."""

    def __init__(self, table: ServoTable, pending: PendingWrites, log: Log, io: ServoIO, watchdog: Watchdog,
                 pacing: Pacing, work: Deferred, reboots: Reboots, kept: KeptSettings, settings: LoopSettings) -> None:
        self.table = table
        self.pending = pending
        self.log = log
        self.io = io
        self.watchdog = watchdog
        self.pacing = pacing
        self.work = work
        self.reboots = reboots
        self.kept = kept  # the servos block's RAM items, written again after a mode change
        self.settings = settings
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        self._last_mode_change: dict[int, float] = {}  # ID -> time.monotonic() of its last mode change
        self._last_clear: dict[int, float] = {}  # ID -> time.monotonic() of its last error clear
        self._mode_failures: dict[int, tuple[str, int]] = {}  # ID -> (mode asked, failed attempts)

    # ---------------------------------------------------------------- goals
    def put_goals(self, writes: Mapping[str, Mapping[int, int]]) -> None:
        """Goal values {item: {ID: pulses}} written with the next sync writes; a tripped bus
        watchdog of those servos is cleared first (a tripped servo refuses goals)."""
        if self.watchdog.any_tripped():
            self.watchdog.clear_tripped(sorted({i for values in writes.values() for i in values}))
        self.pending.put_many(writes.items())

    # ---------------------------------------------------------------- mode changes
    def mode_change_wait(self, dxl_id: int) -> float:
        """Seconds until mode_change_interval_sec has passed since the servo's last mode change."""
        last = self._last_mode_change.get(dxl_id)
        if last is None:
            return 0.0
        interval = float(self.settings.mode_change_interval_s)
        return max(0.0, last + interval - time.monotonic())

    def defer_mode_change(self, dxl_id: int, why: Later, then: object, what: str) -> None:
        """Run ``then`` (a queued request) for this servo once mode_change_interval_sec allows, or at
        the next loop when this loop's operations have used their bus time (``Pacing.ops_wait``); a later
        request replaces it. While the node stops it is dropped (the servo keeps its mode)."""
        if why is Later.STOPPING:
            self.pacing.drop_mode_change(dxl_id)
            return
        if why is Later.BUS_TIME:
            self.log.debug(f"{what}: waits for the next loop (this loop's mode changes used their bus time)")
            self.work.defer(dxl_id, time.monotonic(), what, then)
            return
        if why is Later.RETRY:
            self.work.defer(dxl_id, time.monotonic() + MODE_RETRY_S, what, then)
            return
        left = self.mode_change_wait(dxl_id)
        if dxl_id not in self.work.deferred:
            self.limited(logging.INFO, f"{what}: the last mode change was less than mode_change_interval_sec="
                         f"{self.settings.mode_change_interval_s:g}s ago: applied in {left:.2f}s", f"defer {dxl_id}")
        self.work.defer(dxl_id, time.monotonic() + left, what, then)

    def change_mode(self, dxl_id: int, mode: str, what: str) -> Answer:
        """Torque off -> operating mode -> goals and profiles written back -> torque back as it
        was (safely: goal := present state) -> bus watchdog as the new mode needs. The caller has
        checked that the servo has ``mode``. DONE, FAILED (the bus, after ``MODE_ATTEMPTS``;
        ``failure`` is the warning), or LATER: the last change was less than
        mode_change_interval_sec ago, or this loop's mode changes used their bus time, or the
        node is stopping, or the bus did not take it and it is tried again in ``MODE_RETRY_S``
        (``later`` says which; the caller defers the request: ``CoreCalls.defer_mode_change``)."""
        wait = later(Later.INTERVAL if self.mode_change_wait(dxl_id) > 0 else self.pacing.ops_wait())
        if wait is not None:
            return wait
        previous = self._last_mode_change.get(dxl_id)
        self._last_mode_change[dxl_id] = time.monotonic()
        model = self.table.model(dxl_id)
        own = OWN_GOAL.get(self.io.mode(dxl_id) or "")
        keep = {item: self.io.value(dxl_id, item) for item in MODE_RESET_ITEMS if model.has(item) and item != own}
        torque = self.io.torque_off_for_eeprom(dxl_id)
        written = self._write_mode(dxl_id, model.mode_values[mode])
        for item, value in keep.items():
            if value is not None:
                self.io.write_item(dxl_id, item, value)
        if written:
            self.kept.put_back(dxl_id, f"the mode change to {mode}")
        if torque:
            self.io.torque_on(dxl_id)
        self.watchdog.arm_after_ops(dxl_id)
        if not written:
            return self._mode_failed(dxl_id, mode, what, written, previous)
        self._mode_failures.pop(dxl_id, None)
        self.limited(logging.INFO, f"ID {dxl_id}: operating mode -> {mode}", f"mode {dxl_id}")
        return DONE

    def _write_mode(self, dxl_id: int, code: int) -> Result[bool]:
        """The mode write, read back when it got no good reply: a reply lost on the way is a mode
        taken; a refusal (torque still on: its torque off was lost) is tried once more."""
        written: Result[bool] = Result(False)
        for attempt in range(MODE_WRITE_TRIES):
            written = self.io.write_item(dxl_id, "operating_mode", code)
            if written or written.failure is Failure.NO_SUCH_ITEM:
                return written
            if self.io.read_item(dxl_id, "operating_mode") == code:
                self.log.debug(f"ID {dxl_id}: the mode write's reply was lost ({written.why}); read back: taken")
                return Result(True)
            if attempt + 1 < MODE_WRITE_TRIES:
                self.io.torque_off(dxl_id)
        return written

    def _mode_failed(self, dxl_id: int, mode: str, what: str, written: Result[bool], previous: float | None) -> Answer:
        """A mode change the bus did not take: LATER (tried again, with its goals, in
        ``MODE_RETRY_S``) up to ``MODE_ATTEMPTS`` times, then FAILED. The servo kept its mode, so
        the change does not count for mode_change_interval_sec."""
        if previous is None:
            self._last_mode_change.pop(dxl_id, None)
        else:
            self._last_mode_change[dxl_id] = previous
        asked, failed = self._mode_failures.get(dxl_id, (mode, 0))
        failed = failed + 1 if asked == mode else 1
        if failed < MODE_ATTEMPTS and written.failure is not Failure.NO_SUCH_ITEM:
            self._mode_failures[dxl_id] = (mode, failed)
            self.limited(logging.WARNING, f"{what}: ID {dxl_id} mode change to '{mode}' failed ({written.why}): "
                         f"tried again in {MODE_RETRY_S:g}s with its goals (attempt {failed + 1} of {MODE_ATTEMPTS})",
                         f"mode retry {dxl_id}")
            return Answer(Outcome.LATER, later=Later.RETRY)
        self._mode_failures.pop(dxl_id, None)
        return Answer(Outcome.FAILED, f"{what}: ID {dxl_id} mode change to '{mode}' failed after {failed} "
                      f"attempt(s): {written.why}; the goals that came with it are not written")

    # ---------------------------------------------------------------- error clear
    def clear_error(self, dxl_id: int, keep_rotation: bool, what: str) -> Answer:
        """Clear a hardware error (a servo without one is left alone) the way its family's behaviour
        says (``clearing``): a reboot, where ``keep_rotation`` keeps the multi-turn position through
        the homing offset; the error clear instruction (Y); an item written again (Protocol 1.0:
        Torque Limit). Torque comes back on if it was on, or if the error switched it off (then the
        error, not the user, turned it off). At most once per clear_error_interval_sec per servo
        (else REFUSED). ``failure``: the warning for the user."""
        model = self.table.model(dxl_id)
        error = self.io.read_item(dxl_id, error_state.error_item(model))
        if error is None:
            return answer(False, f"{what}: ID {dxl_id} did not answer the hardware error read: not rebooted")
        if not self._to_clear(dxl_id, model, error):
            self.log.debug(f"{what}: ID {dxl_id} has no hardware error: nothing to clear (not rebooted)")
            return DONE
        refused = self._clear_refused(dxl_id, what)
        if refused is not None:
            return refused
        match model.family.behaviour.clearing:
            case ByClearInstruction(params=params):
                return self._clear_code(dxl_id, error, params, what)
            case ByWritingAgain() as again:
                return self._clear_by_writing_again(dxl_id, error, again, what)
            case ByReboot():
                return self._clear_by_reboot(dxl_id, error, keep_rotation, what)
            case other:
                assert_never(other)

    def _to_clear(self, dxl_id: int, model: Model, error: int) -> bool:
        """Whether there is an error to clear: an error state, or (an error cleared by writing an
        item again: Protocol 1.0, whose status reports the conditions of the moment) an output its
        shutdown cut (that item at 0: Torque Limit) after the cause went away."""
        if error_state.is_error(model, error):
            return True
        clearing = model.family.behaviour.clearing
        return isinstance(clearing, ByWritingAgain) and self.io.read_item(dxl_id, clearing.item) == 0

    def _clear_by_writing_again(self, dxl_id: int, error: int, again: ByWritingAgain, what: str) -> Answer:
        """Protocol 1.0 (e-Manual, Alarm Shutdown): an overload or overheating the Shutdown bits
        cover set Torque Limit to 0; writing it again (to Max Torque, its power-on value) gives the
        servo its output back once the cause is gone; no reboot. Torque back on as after a reboot."""
        model = self.table.model(dxl_id)
        limit = self.io.read_item(dxl_id, again.source)
        if limit is None:
            return answer(False, f"{what}: ID {dxl_id} did not answer the Max Torque read: error not cleared")
        torque = bool(self.io.value(dxl_id, "torque_enable")) or model.family.behaviour.torque_cut(error)
        written = self.io.write_item(dxl_id, again.item, limit)
        if not written:
            return answer(False, f"{what}: ID {dxl_id} Torque Limit not written back: {written.why}")
        if torque:
            self.io.torque_on(dxl_id)
        still = self.io.read_item(dxl_id, error_state.error_item(model))
        cause = error_state.describe(model, error) if error else "the shutdown's cause gone"
        self.log.info(f"ID {dxl_id}: output given back, {cause} (Torque Limit written back to {limit}: cleared, no "
                      "reboot)" + (f"; the servo still reports {error_state.describe(model, still)}" if still else ""))
        return DONE

    def _clear_by_reboot(self, dxl_id: int, error: int, keep_rotation: bool, what: str) -> Answer:
        torque_was = self.io.value(dxl_id, "torque_enable")
        shutdown = self.io.value(dxl_id, "shutdown")
        torque = bool(torque_was) or self.table.model(dxl_id).family.behaviour.torque_cut(error, shutdown)
        before = self.io.read_item(dxl_id, "present_position")
        rebooted = self.reboots.reboot(dxl_id)
        if not rebooted:
            return answer(False, f"{what}: ID {dxl_id} reboot failed: {rebooted.why}")
        self.io.read_item(dxl_id, "torque_enable")
        self.io.read_item(dxl_id, "hardware_error_status")
        if keep_rotation and before is not None:
            line = give_back_turns(self.io, self.work, dxl_id, before)
            if line:
                self.log.info(line)
        if torque:
            self.io.torque_on(dxl_id)
        self.log.info(f"ID {dxl_id}: hardware error cleared ({'turns kept' if keep_rotation else 'turns reset'})")
        return DONE

    def _clear_code(self, dxl_id: int, error: int, params: bytes, what: str) -> Answer:
        """An error code cleared by the servo's error clear; torque back on if it was on or the
        error switched it off (as after a reboot that clears hardware error bits)."""
        model = self.table.model(dxl_id)
        torque = bool(self.io.value(dxl_id, "torque_enable")) or model.family.behaviour.torque_cut(error)
        name = error_state.describe(model, error)
        cleared = self.reboots.clear_error(dxl_id, params)
        if not cleared:
            return answer(False, f"{what}: ID {dxl_id} {name} not cleared: {cleared.why}")
        if torque:
            self.io.torque_on(dxl_id)
        self.log.info(f"ID {dxl_id}: {name} cleared (error clear instruction, no reboot)")
        return DONE

    def _clear_refused(self, dxl_id: int, what: str) -> Answer | None:
        now, interval = time.monotonic(), self.settings.clear_error_interval_s
        last = self._last_clear.get(dxl_id)
        if last is not None and now - last < interval:
            return Answer(Outcome.REFUSED, f"{what}: ID {dxl_id} error clear refused: the last one was "
                          f"{now - last:.2f}s ago (clear_error_interval_sec={interval:g})")
        self._last_clear[dxl_id] = now
        return None
