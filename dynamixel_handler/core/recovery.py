"""Recovery: reboot, a vanished device reopened, silent servos marked and removed."""
from __future__ import annotations

import logging
import time
from typing import Callable

import numpy as np

from ..bus import Failure, Result, ServoBus, dummy_ids
from ..bus.ops import ClearError, Ping, Reboot
from ..servo.table import ServoTable
from ..settings import LoopSettings
from .log_limits import LogLimits, PingLog
from .reconnect_memory import Remembered, differences, remember, restore
from .servo_io import Log, ServoIO
from .state import StepReport
from .watchdog import Watchdog

#: longest wait for a servo to answer again after a reboot instruction [s]
REBOOT_WAIT_S = 1.0
#: a reboot asked for this much before clear_error_interval_sec has passed is not refused [s]
REBOOT_SLACK_S = 0.05
#: least time between two attempts to reopen a vanished device [s]
RECONNECT_INTERVAL_S = 1.0


class Recovery:
    """Reboot, reconnect, ping state and the removal of servos that stopped answering. ``set_up``
    sets a servo up as at start-up (after a reconnect). A servo silent too long is removed from the
    table (the other parts observe that: ``ServoTable.watch_removals``). Of the settings:
    ``clear_error_interval_s`` (also between two reboots of a servo) and
    ``no_response_auto_remove``."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, io: ServoIO, watchdog: Watchdog,
                 settings: LoopSettings, set_up: Callable[[int], None]) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.io = io
        self.watchdog = watchdog
        self.settings = settings
        self._set_up = set_up
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        #: the ping false / answers again lines, at most one a second per servo
        self.ping_log = PingLog(lambda level, msg: self.log.log(level, msg))
        self.had_device = False  # the device was open at start-up: its loss is watched for
        self.reconnects = 0
        self.device_lost = False
        self.device_lost_since: float | None = None  # time.time() when the device was found gone
        self._next_reconnect = 0.0
        #: IDs handled when the device went, set up again when it is back (None: not gone)
        self._lost_ids: list[int] | None = None
        #: silent after a reconnect: set up as at start-up once they answer
        self._not_set_up: set[int] = set()
        self._last_reboot: dict[int, float] = {}  # ID -> time.monotonic() of its last reboot
        #: (ID, why): the servos block's RAM items written again after a reboot (``KeptSettings``)
        self.put_back: Callable[[int, str], None] = lambda dxl_id, why: None
        #: (ID, item): whether the servos block sets the item (it then wins over what the servo had)
        self.file_sets: Callable[[int, str], bool] = lambda dxl_id, item: False
        #: what was known of each servo when the device went: put back after its set-up
        self._memory: dict[int, Remembered] = {}

    def reboot(self, dxl_id: int) -> Result[bool]:
        """Reboot and wait until the servo answers again (it needs a few hundred ms; this blocks the
        loop meanwhile, so that nothing is sent to a servo that is still booting). At most once per
        clear_error_interval_sec per servo, as the error clear (a reboot too): a reboot asked for
        sooner is refused with one line a second (False)."""
        refused = self._reboot_refused(dxl_id)
        if refused:
            return Result(False, Failure.HELD_BACK, refused)
        # a reboot resets the RAM area: what the handler had set there comes back afterwards
        kept = {item: self.table.value(item, dxl_id) for item in ("profile_acceleration", "profile_velocity")}
        protocol = self.table.model(dxl_id).protocol
        rebooted = self.bus.execute(Reboot(dxl_id, protocol))  # sent once (a late acknowledgement: rebooted all the same)
        if rebooted or self.bus.is_open:  # unacknowledged, it may be booting: wait for it all the same
            deadline = time.monotonic() + REBOOT_WAIT_S
            time.sleep(0.02)
            while self.bus.execute(Ping(dxl_id, 0, protocol)).value is None:
                if time.monotonic() > deadline:
                    self.log.warning(f"ID {dxl_id}: no answer {REBOOT_WAIT_S:g}s after reboot")
                    break
                time.sleep(0.02)
            for item, value in kept.items():
                if value is not None:
                    self.io.write_item(dxl_id, item, value)
            self.put_back(dxl_id, "a reboot")
            if dxl_id in self.table:
                self.watchdog.arm_watchdog(dxl_id)
        return rebooted

    def clear_error(self, dxl_id: int, params: bytes) -> Result[bool]:
        """The error clear of a servo that has one (Y: the Clear instruction with ``params``): no
        reboot; the error item and torque are read again afterwards."""
        cleared = self.bus.execute(ClearError(dxl_id, params))
        model = self.table.model(dxl_id)
        codes = model.family.error_codes
        for item in ("torque_enable", codes.item if codes is not None else ""):
            if model.has(item):
                self.io.read_item(dxl_id, item)
        return cleared

    def _reboot_refused(self, dxl_id: int) -> str:
        """Why a reboot of ``dxl_id`` now is refused ("": it is not)."""
        now, interval = time.monotonic(), float(self.settings.clear_error_interval_s)
        last = self._last_reboot.get(dxl_id)
        # the slack: an error clear checks its own interval a few reads before its reboot, so its
        # next clear, allowed, must not find the reboot a few milliseconds too soon
        if last is not None and now - last < interval - REBOOT_SLACK_S:
            why = (f"the last one was {now - last:.2f}s ago "
                   f"(at most one per clear_error_interval_sec={interval:g}s per servo)")
            self.limited(logging.WARNING, f"ID {dxl_id}: reboot refused: {why}", f"reboot {dxl_id}")
            return f"refused: {why}"
        self._last_reboot[dxl_id] = now
        return ""

    def reconnect(self, report: StepReport) -> None:
        """The device vanished: servos on it read ping false; try to reopen it once a second. Nothing
        counts towards a servo's removal meanwhile (the device is gone, not the servo); once it is
        back, every servo handled when it went is pinged and set up as at start-up."""
        dummies = dummy_ids(self.bus)
        if not self.device_lost:
            self.device_lost = True
            self.device_lost_since = time.time()
            self._lost_ids = [i for i in self.table.ids if i not in dummies]
            self._memory = {i: remember(self.table, i) for i in self._lost_ids}
            self.log.error(f"{self.bus.device} is gone (the port hung up: unplugged, or another process reading it?): "
                           f"reconnecting every {RECONNECT_INTERVAL_S:g}s; states keep being published with ping false")
        for pos, dxl_id in enumerate(self.table.ids):
            if dxl_id not in dummies:
                self.table.ping[pos] = False
        report.groups.add("status")
        now = time.monotonic()
        if now < self._next_reconnect:
            return
        self._next_reconnect = now + RECONNECT_INTERVAL_S
        try:
            self.bus.reopen()
        except Exception as exc:  # BusError with the reason; anything else must not stop the loop
            self.log.debug(f"reconnect failed: {exc}")
            return
        self.device_lost = False
        self.device_lost_since = None
        self.reconnects += 1
        self.log.info(f"{self.bus.device} is back: reconnected (reconnect #{self.reconnects})")
        self._set_up_again([i for i in (self._lost_ids or []) if i in self.table])
        self._lost_ids = None

    def _set_up_again(self, ids: list[int]) -> None:
        """After a reconnect: each servo pinged; one that answers is set up as at start-up (its
        power may have gone with the adapter: RAM at its defaults, torque off); one that does not
        stays handled with ping false, is pinged again as any silent servo, and is set up as soon
        as it answers (``set_up_returned``)."""
        answered, silent = [], []
        for dxl_id in ids:
            if self.bus.execute(Ping(dxl_id, 1, self.table.model(dxl_id).protocol)).value is None:
                silent.append(dxl_id)
                continue
            pos = self.table.index[dxl_id]
            self.table.ping[pos] = True
            self.table.no_response[pos] = 0
            self._set_up_as_before(dxl_id)
            answered.append(dxl_id)
        self.log.info(f"after the reconnect: {len(answered)} servo(s) {answered} answer and are set up as at start-up"
                      + (f"; no answer yet from {silent} (pinged again as silent servos, set up once they answer)"
                         if silent else ""))
        self._not_set_up.update(silent)

    @property
    def set_up_due(self) -> bool:
        """A servo silent after a reconnect answers now and waits for its set-up."""
        return bool(self._not_set_up) and any(self.table.ping[self.table.index[i]] for i in self._not_set_up
                                              if i in self.table)

    def set_up_returned(self) -> None:
        """Set up as at start-up each servo that was silent after a reconnect and answers now."""
        for dxl_id in sorted(self._not_set_up):
            if dxl_id not in self.table:
                self._not_set_up.discard(dxl_id)
            elif self.table.ping[self.table.index[dxl_id]]:
                self._not_set_up.discard(dxl_id)
                self.log.info(f"ID {dxl_id}: answers after the reconnect: set up as at start-up")
                self._set_up_as_before(dxl_id)

    def _set_up_as_before(self, dxl_id: int) -> None:
        """Set up as at start-up, then what it had before the device went (``reconnect_memory``):
        EEPROM items that differ named, its mode and profiles back, a goal not resumed said."""
        before = self._memory.pop(dxl_id, None)
        def say(level: int, msg: str) -> None:
            self.log.log(level, msg)
        if before is not None:
            differences(self.io, dxl_id, before, say)
        self._set_up(dxl_id)
        if before is not None:
            restore(self.io, dxl_id, before, lambda item: self.file_sets(dxl_id, item), say, self.put_back)

    def update_ping(self, addressed: np.ndarray, answered: np.ndarray) -> None:
        table = self.table
        silent = addressed & ~answered
        if self.device_lost or (self.had_device and not self.bus.is_open):
            # the device is gone, not the servos: nothing counted, no line per servo (one line says it)
            table.ping[silent] = False
            table.no_response[answered] = 0
            table.ping[answered] = True
            return
        ping_log = self.ping_log
        any_silent = silent.any()
        if any_silent:
            for pos in np.flatnonzero(silent & table.ping):
                ping_log.change(table.ids[pos], False)
        back = answered & ~table.ping
        if back.any():
            for pos in np.flatnonzero(back):
                ping_log.change(table.ids[pos], True)
                # its bus watchdog may have tripped meanwhile (it then refuses goals): armed anew
                # before the next commands are written
                self.watchdog.request_arm(table.ids[pos])
        ping_log.flush()
        # each read or ping of the servo that got no answer counts (a silent servo is only pinged every
        # recheck_loops loops): the removal comes after no_response_id_auto_remove_count
        # unanswered requests in a row
        if any_silent:
            table.no_response[silent] += 1
            table.ping[silent] = False
        table.no_response[answered] = 0
        table.ping[answered] = True
        limit = self.settings.no_response_auto_remove
        if limit > 0 and any_silent:
            for pos in reversed(np.flatnonzero(table.no_response >= limit)):
                dxl_id = table.ids[pos]
                self.log.warning(f"ID {dxl_id}: no response {limit} times in a row: removed "
                                 "(add it again with the shortcut add_id)")
                table.remove(dxl_id)

    @property
    def device_gone(self) -> bool:
        """The device that was open at start-up is closed (it vanished): ``reconnect`` has work."""
        return self.had_device and not self.bus.is_open

    def forget(self, dxl_id: int) -> None:
        """The servo is no longer handled."""
        self.ping_log.forget(dxl_id)
        self._not_set_up.discard(dxl_id)
