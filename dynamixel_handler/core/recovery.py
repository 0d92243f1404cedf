"""Recovery: a vanished device reopened, its servos set up again, silent servos marked and removed."""
from __future__ import annotations

import time

import numpy as np

from ..bus import ServoBus, dummy_ids
from ..bus.ops import Ping
from ..servo.table import ServoTable
from ..settings import LoopSettings
from .log_limits import LogLimits, PingLog
from .reconnect_memory import Remembered, booted, differences, remember, restore
from .servo_io import Log, ServoIO
from .servo_setup import ServoSetup
from .state import StepReport
from .watchdog import Watchdog

#: least time between two attempts to reopen a vanished device [s]
RECONNECT_INTERVAL_S = 1.0
#: steps in which a servo back from silence is asked again whether it booted, when the reads that
#: would tell get no answer
BOOT_ASKS = 20


class Recovery:
    """Reconnect, ping state and the removal of servos that stopped answering. ``setup`` sets a
    servo up as at start-up (after a reconnect). A servo silent too long is removed from the
    table (the other parts observe that: ``ServoTable.watch_removals``). Of the settings:
    ``no_response_auto_remove``."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, io: ServoIO, watchdog: Watchdog,
                 settings: LoopSettings, setup: ServoSetup) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.io = io
        self.watchdog = watchdog
        self.settings = settings
        self.setup = setup  # a servo set up as at start-up after a reconnect; its servos block
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        #: the ping false / answers again lines, at most one a second per servo
        self.ping_log = PingLog(lambda level, msg: self.log.log(level, msg))
        self.had_device = False  # the device was open at start-up (watch_device): its loss is watched for
        self.reconnects = 0
        self.device_lost = False
        self.device_lost_since: float | None = None  # time.time() when the device was found gone
        self._next_reconnect = 0.0
        #: IDs handled when the device went, set up again when it is back (None: not gone)
        self._lost_ids: list[int] | None = None
        #: silent after a reconnect: set up as at start-up once they answer
        self._not_set_up: set[int] = set()
        #: what was known of each servo when the device went: put back after its set-up
        self._memory: dict[int, Remembered] = {}
        #: what was known of each servo that went silent (it may come back booted)
        self._silent_at: dict[int, Remembered] = {}
        #: servos that answer again: whether they booted meanwhile looked at before the next step
        #: (ID -> the times it may still be asked)
        self._back: dict[int, int] = {}

    def watch_device(self) -> None:
        """At start-up: the device is open now, so its loss is watched for from here on."""
        self.had_device = self.bus.is_open

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
            if self.bus.execute(Ping(dxl_id, 1, protocol=self.table.model(dxl_id).protocol)).value is None:
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

    def _set_up_as_before(self, dxl_id: int, torque: bool | None = None) -> None:
        """Set up as at start-up, then what it had before the device went (``reconnect_memory``):
        EEPROM items that differ named, the whole turns a multi-turn servo lost given back, its mode
        and profiles back, a goal not resumed said. ``torque``: as ``ServoSetup.setup_servo``."""
        before = self._memory.pop(dxl_id, None)
        def say(level: int, msg: str) -> None:
            self.log.log(level, msg)
        if before is not None:
            differences(self.io, dxl_id, before, say)
            if before.position is not None:  # before the set-up turns its torque on
                self.setup.give_back_turns(dxl_id, before.position)
        self.setup.setup_servo(dxl_id, torque)
        if before is not None:
            kept = self.setup.kept
            restore(self.io, dxl_id, before, lambda item: kept.sets(dxl_id, item), say, kept.put_back)

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
                self._note_silent(table.ids[pos])
        back = answered & ~table.ping
        if back.any():
            for pos in np.flatnonzero(back):
                self._answers_again(table.ids[pos])
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

    def _answers_again(self, dxl_id: int) -> None:
        self.ping_log.change(dxl_id, True)
        # it may have booted meanwhile, however short the silence (a brown-out resets a servo in
        # milliseconds): asked before the next step (a read or three; a lost read on a noisy line too)
        if dxl_id in self._silent_at:
            self._back[dxl_id] = BOOT_ASKS
        # its bus watchdog may have tripped meanwhile (it then refuses goals): armed anew before
        # the next commands are written
        self.watchdog.request_arm(dxl_id)

    def _note_silent(self, dxl_id: int) -> None:
        """A servo went silent: what it had, should it come back booted."""
        self._silent_at[dxl_id] = remember(self.table, dxl_id)


    @property
    def back_due(self) -> bool:
        """A servo that went silent answers again: whether it booted meanwhile is to be looked at."""
        return bool(self._back)

    def look_at_returned(self) -> None:
        """Each servo that answers again after it went silent: one that lost its power meanwhile
        (``reconnect_memory.booted``: torque dropped, or RAM at its defaults) is set up again as
        after a reconnect, with the torque it had (its turns given back, its mode and profiles
        back); one that did not is left as it is."""
        for dxl_id, asks in sorted(self._back.items()):
            before = self._silent_at.get(dxl_id)
            was = booted(self.io, dxl_id, before) if before is not None and dxl_id in self.table else False
            if was is None and asks > 1:  # no answer to the reads that tell: asked again next step
                self._back[dxl_id] = asks - 1
                continue
            del self._back[dxl_id]
            self._silent_at.pop(dxl_id, None)
            if was and before is not None:
                self._set_up_after_boot(dxl_id, before)

    def _set_up_after_boot(self, dxl_id: int, before: Remembered) -> None:
        self.log.warning(f"ID {dxl_id}: answers again after a power loss (RAM at its defaults): set up again, "
                         f"torque {'on' if before.torque else 'left off'} as it was")
        self._memory[dxl_id] = before
        self._set_up_as_before(dxl_id, torque=bool(before.torque))

    @property
    def device_gone(self) -> bool:
        """The device that was open at start-up is closed (it vanished): ``reconnect`` has work."""
        return self.had_device and not self.bus.is_open

    def forget(self, dxl_id: int) -> None:
        """The servo is no longer handled."""
        self.ping_log.forget(dxl_id)
        self._not_set_up.discard(dxl_id)
        self._silent_at.pop(dxl_id, None)
        self._back.pop(dxl_id, None)
