"""The handler's life on the bus: start-up, one loop step, shutdown. ROS-free.

``Handler`` is a front over parts with one job each (``dynamixel_handler/core``), each an object
with its own state that is given what it needs (the bus, the servo table, the pending writes, its
slice of the parameters, the log) and the other parts it calls:

    servo_io     ServoIO: one servo at a time: read/write an item, its mode, torque on without a jump
    group_io     GroupIO: one item of many servos in one sync write or read per layout
    pacing       Pacing: while bus watchdogs are armed, reads cut and mode changes spread over loops;
                 a stop drops the rest
    read_plan    ReadPlan: pub ratios -> the items due -> sync reads per control-table layout; replies
                 gathered and stored
    write_batch  WriteBatch: pending values -> one sync write per item, built ahead and sent in one go
    deferred     Deferred: EEPROM writes spared and coalesced, mode changes asked for too soon, the
                 operation queue
    watchdog     Watchdog: the bus watchdog time from the loop period; arming, clearing, trips
    kept_settings KeptSettings: the servos block, checked, applied, put back after what resets RAM
    reboots      Reboots: a servo's reboot (at most one per interval) and error clear
    servo_setup  ServoSetup: the set-up every servo gets (start-up, add_id, after a reconnect)
    recovery     Recovery: a vanished device reopened, silent servos marked and removed
    startup      Startup: scan, expected count, each servo set up (also add_id)
    e_stop       EStop: every servo holds, moving requests refused until released; hold_all
    requests     Requests: what commands may ask, checked: goals, a mode change, an error clear
    calls        CoreCalls: the command side's typed calls in the loop thread (``ServoAccess.core``)
    intake       Intake: the queue of requests from any thread, each to the part that takes it
    step         Step: one loop step in four phases (prepare, send, complete, finish), read logs
    shutdown     Shutdown: the servos left as term/* say
    state        StepReport: what one loop step did
    log_limits   LogLimits, PingLog: lines that can repeat, at most one a second per cause and servo

``Handler.step()`` runs queued operations (torque, mode, reboot...), writes pending values in
grouped sync writes, reads what the ratios ask for this loop, and returns a ``StepReport`` that
says which groups were read. The ROS layer turns the table into messages. The parts read typed
settings (``dynamixel_handler.settings``), handed out in one place (``parts.part_settings``): each
part gets its slice, again whenever ``settings`` is replaced.
"""
from __future__ import annotations

import logging
from typing import Callable

from ..bus import ServoBus
from ..config import Config
from ..control_table import OPERATING_MODES, Model
from ..errors import Interrupted, StartupError
from ..settings import Settings
from .api import LoopFigures, ServoAccess
from .deferred import EEPROM_WRITE_INTERVAL_S
from .intake import Taker
from .log_limits import LogLimits
from .parts import build_parts
from .reboots import REBOOT_WAIT_S
from .recovery import RECONNECT_INTERVAL_S
from .servo_io import Log
from .state import RECHECK_LOOPS, StepReport
from .watchdog import WATCHDOG_MAX_MS, WATCHDOG_MODES, WATCHDOG_TRIPPED


class Handler:
    """Owns the servos of one bus: ``start()``, then ``step()`` (or its phases) every loop, then
    ``shutdown()``. Commands reach it as request values queued for the loop thread (``submit``),
    each handed by the ``Intake``'s table to the part that takes it (``attach``); in the loop thread
    they ask through typed methods (``core``, ``calls.CoreCalls``); goals end as pending writes
    (``pending``). Implements ``core.api.ServoAccess`` and the runner's ``LoopCore``
    by handing each call to the part that does it. ``tripped_once`` False: every goal command looks
    for tripped bus watchdogs servo by servo (for tests and comparisons). ``settings``: the typed
    settings, or the validated parameters (``config.validate``) they are taken from."""

    def __init__(self, bus: ServoBus, settings: Settings | Config, logger: Log | None = None, *,
                 tripped_once: bool = True, interrupted: Callable[[], bool] = lambda: False) -> None:
        self._log: Log = logger or logging.getLogger("dynamixel_handler")
        self._settings = settings.settings if isinstance(settings, Config) else settings
        #: why operations are not taken now (a lifecycle node that is not active); None: they are
        self.refuse_ops: str | None = None
        p = self._parts = build_parts(bus, self._settings, self._log, interrupted, tripped_once)
        self.bus, self.table, self.pending = p.bus, p.table, p.pending
        self.io, self.group, self.pacing, self.reads, self.writes = p.io, p.group, p.pacing, p.reads, p.writes
        self.watchdog, self.work, self.intake, self.recovery = p.watchdog, p.work, p.intake, p.recovery
        self.startup, self.requests, self.steps, self.ending = p.startup, p.requests, p.steps, p.ending
        self.e_stop, self.leds, self.setup, self.reboots = p.e_stop, p.leds, p.setup, p.reboots
        #: what the command side asks of the core in the loop thread (``ServoAccess.core``)
        self.core = p.core
        self._limited = LogLimits(lambda level, msg: self._log.log(level, msg))
        self.table.watch_removals(self._say_removed)  # after the parts forgot it: one line says so

    # ---------------------------------------------------------------- what every part shares
    @property
    def settings(self) -> Settings:
        return self._settings

    @settings.setter
    def settings(self, settings: Settings) -> None:
        """New settings (replaced as a whole): each part gets its new slice."""
        self._settings = settings
        self._parts.apply(settings)

    @property
    def log(self) -> Log:
        return self._log

    @log.setter
    def log(self, log: Log) -> None:
        self._log = log
        self._parts.set_log(log)

    # ---------------------------------------------------------------- life on the bus
    def start(self) -> None:
        """Scan, keep the servos of the used series, and set each up as the parameters say."""
        self.recovery.watch_device()
        self.startup.start()

    def shutdown(self) -> None:
        """Leave the servos as term/* say (``core.shutdown``); a start-up refused before its first
        write (a servos block refused, too few servos found) writes nothing here either: every
        servo is left as it was found (torque included)."""
        if not self.startup.wrote:
            if len(self.table):
                self.log.info("start-up wrote nothing: the servos are left as they were found (torque unchanged)")
            return
        dropped = self.pacing.dropped_mode_changes | set(self.work.deferred)
        self.ending.shutdown(dropped, self.watchdog.user_ids())

    def step(self) -> StepReport:
        return self.steps.step()

    def figures(self) -> LoopFigures:
        """The loop's counts, device and watchdog figures, as one value."""
        recovery = self.recovery
        return LoopFigures(loop_count=self.steps.loop_count, loop_period_s=self.watchdog.loop_period_s,
                           recheck_loops=self.steps.settings.recheck_loops, device_lost=recovery.device_lost,
                           device_lost_since=recovery.device_lost_since, reconnects=recovery.reconnects,
                           watchdog_trips=self.watchdog.trips, e_stop=self.e_stop.engaged_why())

    # ---------------------------------------------------------------- ServoAccess: what is known
    @property
    def handled_ids(self) -> list[int]:
        return list(self.table.ids)

    def handles(self, dxl_id: int) -> bool:
        return dxl_id in self.table

    def model(self, dxl_id: int) -> Model:
        return self.table.model(dxl_id)

    def mode(self, dxl_id: int) -> str | None:
        return self.io.mode(dxl_id)

    def value(self, dxl_id: int, item: str) -> int | None:
        return self.io.value(dxl_id, item)

    # ---------------------------------------------------------------- ServoAccess: requests
    def submit(self, request: object, what: str = "") -> None:
        self.intake.submit(request, what)

    def attach(self, part: Taker) -> None:
        """A command-side part that takes queued requests (``TAKES``), attached by who builds it."""
        self.intake.attach(part)

    def drop_ops(self) -> int:
        return self.intake.drop()

    def read_item(self, dxl_id: int, item: str) -> int | None:
        return self.io.read_item(dxl_id, item)

    def _say_removed(self, dxl_id: int) -> None:
        self._limited(logging.INFO, f"ID {dxl_id}: removed from the handled servos", f"removed {dxl_id}")


def _as_servo_access(handler: Handler) -> ServoAccess:
    """The type checker holds ``Handler`` to ``ServoAccess`` here."""
    return handler


def mode_value(name: str, model: Model | None = None) -> int:
    """The Operating Mode register value of a mode (on ``model``: its own values, e.g. XL-320)."""
    return (model.mode_values if model is not None else OPERATING_MODES)[name]


__all__ = ["EEPROM_WRITE_INTERVAL_S", "Handler", "Interrupted", "RECHECK_LOOPS", "RECONNECT_INTERVAL_S", "REBOOT_WAIT_S",
           "StartupError", "StepReport", "WATCHDOG_MAX_MS", "WATCHDOG_MODES", "WATCHDOG_TRIPPED", "mode_value"]
