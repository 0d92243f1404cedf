"""Recovery: reboot, a vanished device reopened, silent servos marked and removed."""
from __future__ import annotations

import time

import numpy as np

from .state import StepReport
from .watchdog import Watchdog

#: longest wait for a servo to answer again after a reboot instruction [s]
REBOOT_WAIT_S = 1.0
#: least time between two attempts to reopen a vanished device [s]
RECONNECT_INTERVAL_S = 1.0


class Recovery(Watchdog):
    """Reboot, reconnect, ping state and the removal of servos that stopped answering."""

    def reboot(self, dxl_id: int) -> bool:
        """Reboot and wait until the servo answers again (it needs a few hundred ms; this blocks the
        loop meanwhile, so that nothing is sent to a servo that is still booting)."""
        # a reboot resets the RAM area: what the handler had set there comes back afterwards
        kept = {item: self.table.value(item, dxl_id) for item in ("profile_acceleration", "profile_velocity")}
        ok = self.bus.reboot(dxl_id)
        if ok:
            deadline = time.monotonic() + REBOOT_WAIT_S
            time.sleep(0.02)
            while self.bus.ping(dxl_id, retries=0) is None:
                if time.monotonic() > deadline:
                    self.log.warning(f"ID {dxl_id}: no answer {REBOOT_WAIT_S:g}s after reboot")
                    break
                time.sleep(0.02)
            for item, value in kept.items():
                if value is not None:
                    self.write_item(dxl_id, item, value)
            if dxl_id in self.table:
                self.arm_watchdog(dxl_id)
        return ok

    def _reconnect(self, report: StepReport) -> None:
        """The device vanished: servos on it read ping false; try to reopen it once a second."""
        dummies = self.bus.dummies
        if not self.device_lost:
            self.device_lost = True
            self.device_lost_since = time.time()
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
        for dxl_id in list(self.table.ids):
            if dxl_id not in dummies and self.bus.ping(dxl_id, retries=1) is not None:
                self.table.ping[self.table.index[dxl_id]] = True
                self.arm_watchdog(dxl_id)

    def _update_ping(self, addressed: np.ndarray, answered: np.ndarray) -> None:
        table = self.table
        silent = addressed & ~answered
        any_silent = silent.any()
        if any_silent:
            for pos in np.flatnonzero(silent & table.ping):
                self.log.warning(f"ID {table.ids[pos]}: no response (ping false)")
        back = answered & ~table.ping
        if back.any():
            for pos in np.flatnonzero(back):
                self.log.info(f"ID {table.ids[pos]}: answers again")
                # its bus watchdog may have tripped meanwhile (it then refuses goals): armed anew
                # before the next commands are written
                self._to_arm.add(table.ids[pos])
        # each read or ping of the servo that got no answer counts (a silent servo is only pinged every
        # recheck_loops loops): the removal comes after no_response_id_auto_remove_count
        # unanswered requests in a row
        if any_silent:
            table.no_response[silent] += 1
            table.ping[silent] = False
        table.no_response[answered] = 0
        table.ping[answered] = True
        limit = self.config["no_response_id_auto_remove_count"]
        if limit > 0:
            for pos in reversed(np.flatnonzero(table.no_response >= limit)):
                dxl_id = table.ids[pos]
                self.log.warning(f"ID {dxl_id}: no response {limit} times in a row: removed "
                                 "(add it again with the shortcut add_id)")
                self.remove_id(dxl_id)

    def remove_id(self, dxl_id: int) -> None:
        if dxl_id in self.table:
            self.table.remove(dxl_id)
            self.pending.drop_ids([dxl_id])
            self.deferred.pop(dxl_id, None)
            self.watchdog_user.pop(dxl_id, None)
            for key in [k for k in self._eeprom_deferred if k[0] == dxl_id]:
                del self._eeprom_deferred[key]
            self.log.info(f"ID {dxl_id}: removed from the handled servos")
