"""Reboots and error clears of one servo: at most one reboot per clear_error_interval_sec per
servo, the servo waited for until it answers, what the handler had set in its RAM put back."""
from __future__ import annotations

import logging
import time

from ..bus import Failure, Result, ServoBus
from ..bus.ops import ClearError, Ping, Reboot
from ..servo.table import ServoTable
from ..settings import LoopSettings
from .kept_settings import KeptSettings
from .log_limits import LogLimits
from .servo_io import Log, ServoIO
from .watchdog import Watchdog

#: longest wait for a servo to answer again after a reboot instruction [s]
REBOOT_WAIT_S = 1.0
#: a reboot asked for this much before clear_error_interval_sec has passed is not refused [s]
REBOOT_SLACK_S = 0.05


class Reboots:
    """A servo's reboot and error clear (used by the set-up, the error clear of a command and the
    reboot command). Of the settings: ``clear_error_interval_s``."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, io: ServoIO, watchdog: Watchdog,
                 kept: KeptSettings, settings: LoopSettings) -> None:
        self.bus, self.table, self.log, self.io, self.watchdog = bus, table, log, io, watchdog
        self.kept = kept
        self.settings = settings
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        self._last_reboot: dict[int, float] = {}  # ID -> time.monotonic() of its last reboot

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
        rebooted = self.bus.execute(Reboot(dxl_id, protocol=protocol))  # sent once (a late acknowledgement: rebooted all the same)
        if rebooted or self.bus.is_open:  # unacknowledged, it may be booting: wait for it all the same
            deadline = time.monotonic() + REBOOT_WAIT_S
            time.sleep(0.02)
            while self.bus.execute(Ping(dxl_id, 0, protocol=protocol)).value is None:
                if time.monotonic() > deadline:
                    self.log.warning(f"ID {dxl_id}: no answer {REBOOT_WAIT_S:g}s after reboot")
                    break
                time.sleep(0.02)
            for item, value in kept.items():
                if value is not None:
                    self.io.write_item(dxl_id, item, value)
            self.kept.put_back(dxl_id, "a reboot")
            if dxl_id in self.table:
                self.watchdog.arm_watchdog(dxl_id)
        return rebooted

    def clear_error(self, dxl_id: int, params: bytes) -> Result[bool]:
        """The error clear of a servo that has one (Y: the Clear instruction with ``params``): no
        reboot; the error item and torque are read again afterwards."""
        model = self.table.model(dxl_id)
        cleared = self.bus.execute(ClearError(dxl_id, params, protocol=model.protocol))
        for item in ("torque_enable", model.family.behaviour.error_item):
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
