"""The core's parts built and wired as ``Handler.__init__`` does, without the Handler: each part over
the bus given (a ``FakeBus`` in test/core), with the real neighbours it calls and its slice of the
settings (``slices``, as ``core.handler._settings``). test/test_unit_coverage.py compares both the
slices and the wiring with a Handler's, so a part tested here is the part the Handler runs.

    parts = build(FakeBus({1: XM430}), Settings(), log)
    parts.startup.start(); parts.steps.step()
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Callable

from dynamixel_handler.core.deferred import Deferred
from dynamixel_handler.core.group_io import GroupIO
from dynamixel_handler.core.intake import Intake
from dynamixel_handler.core.log_limits import LogLimits
from dynamixel_handler.core.pacing import Pacing
from dynamixel_handler.core.read_plan import ReadPlan, ReadSettings, every
from dynamixel_handler.core.recovery import Recovery
from dynamixel_handler.core.request_types import (
    AddServo,
    Answer,
    CancelDeferred,
    ChangeMode,
    ClearError,
    DeferModeChange,
    Reboot,
    RemoveServo,
    SetGoals,
    SetUserWatchdog,
    TorqueOff,
    TorqueOn,
    WantHandled,
    WriteEeprom,
    WriteItem,
    answer,
)
from dynamixel_handler.core.requests import Requests
from dynamixel_handler.core.servo_io import Log, ServoIO
from dynamixel_handler.core.shutdown import Shutdown
from dynamixel_handler.core.startup import Startup, StartupSettings
from dynamixel_handler.core.state import recheck_loops
from dynamixel_handler.core.step import Step, StepSettings
from dynamixel_handler.core.watchdog import Watchdog, WatchdogSettings
from dynamixel_handler.core.write_batch import WriteBatch
from dynamixel_handler.servos import PendingWrites, ServoTable
from dynamixel_handler.settings import LoopSettings, Settings, TermSettings

#: the parts, by the names the Handler gives them
PART_NAMES = ("bus", "table", "pending", "io", "group", "pacing", "reads", "writes", "watchdog", "work", "intake",
              "recovery", "startup", "requests", "steps", "ending")


@dataclass(frozen=True)
class Slices:
    """What each part reads of the settings (field for field as the Handler's)."""

    reads: ReadSettings
    watchdog: WatchdogSettings
    loop: LoopSettings
    startup: StartupSettings
    step: StepSettings
    term: TermSettings
    split_write: bool


def slices(s: Settings) -> Slices:
    return Slices(
        reads=ReadSettings(s.ratios, s.method.fast_read, s.method.split_read),
        watchdog=WatchdogSettings(float(s.loop.rate_hz), every(s.ratios), float(s.start.bus_watchdog_ms),
                                  s.term.servo_auto_stop),
        loop=s.loop,
        startup=StartupSettings(s.scan, s.start, s.loop.debug),
        step=StepSettings(recheck_loops(s.loop.rate_hz), s.logs),
        term=s.term,
        split_write=s.method.split_write,
    )


@dataclass
class Parts:
    """Every part of one bus, as the Handler holds them; ``stopping`` stands for a node asked to exit
    (start-up stops between two servos, mode changes are dropped)."""

    bus: Any
    table: ServoTable
    pending: PendingWrites
    io: ServoIO
    group: GroupIO
    pacing: Pacing
    reads: ReadPlan
    writes: WriteBatch
    watchdog: Watchdog
    work: Deferred
    intake: Intake
    recovery: Recovery
    startup: Startup
    requests: Requests
    steps: Step
    ending: Shutdown
    log: Log
    stopping: list[bool] = field(default_factory=lambda: [False])

    def say_removed(self, dxl_id: int) -> None:
        self.limited(logging.INFO, f"ID {dxl_id}: removed from the handled servos", f"removed {dxl_id}")

    def __post_init__(self) -> None:
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))


def core_routes(p: Parts) -> dict[type, Callable[[Any], Answer | None]]:
    """Each core request type to the part that does it, as the Handler registers them."""
    return {
        SetGoals: p.requests.put_goals,
        ChangeMode: p.requests.change_mode,
        DeferModeChange: p.requests.defer_mode_change,
        CancelDeferred: p.requests.cancel_deferred,
        ClearError: p.requests.clear_error,
        TorqueOn: lambda r: answer(p.io.torque_on(r.dxl_id)),
        TorqueOff: lambda r: answer(p.io.torque_off(r.dxl_id)),
        WriteItem: lambda r: answer(p.io.write_item(r.dxl_id, r.item, r.pulses)),
        WriteEeprom: lambda r: answer(p.work.write_eeprom(r.dxl_id, r.item, r.pulses)),
        Reboot: lambda r: answer(p.recovery.reboot(r.dxl_id)),
        AddServo: lambda r: answer(p.startup.add_id(r.dxl_id), f"ID {r.dxl_id} not added"),
        RemoveServo: lambda r: p.table.remove(r.dxl_id),
        WantHandled: lambda r: p.startup.want_handled(r.dxl_id, r.handled),
        SetUserWatchdog: lambda r: p.watchdog.set_user(r.dxl_id, r.pulses),
    }


def build(bus: Any, settings: Settings | None = None, log: Log | None = None, *, tripped_once: bool = True) -> Parts:
    """The parts over ``bus`` with ``settings`` (default: the defaults), wired as the Handler wires
    them: the same constructor arguments, the removal watchers and the request routes."""
    settings = settings if settings is not None else Settings()
    log = log if log is not None else logging.getLogger("parts")
    s = slices(settings)
    table, pending = ServoTable(), PendingWrites()
    stopping = [False]

    def interrupted() -> bool:
        return stopping[0]

    io = ServoIO(bus, table, log)
    group = GroupIO(bus, table, log)
    pacing = Pacing(bus, table, interrupted)
    reads = ReadPlan(bus, table, log, pacing, s.reads)
    writes = WriteBatch(bus, table, pending, log, s.split_write)
    watchdog = Watchdog(table, log, io, group, s.watchdog, tripped_once)
    work = Deferred(table, log, io)
    intake = Intake(log)
    set_up: list[Startup] = []  # Recovery sets a servo up again through the Startup built after it
    recovery = Recovery(bus, table, log, io, watchdog, s.loop, lambda dxl_id: set_up[0].setup_servo(dxl_id))
    startup = Startup(bus, table, log, io, work, recovery, watchdog, s.startup, interrupted)
    set_up.append(startup)
    requests = Requests(table, pending, log, io, watchdog, pacing, work, recovery, s.loop)
    steps = Step(bus, table, log, reads, writes, pacing, watchdog, recovery, work, intake, startup, s.step)
    ending = Shutdown(bus, table, log, io, group, s.term)
    parts = Parts(bus, table, pending, io, group, pacing, reads, writes, watchdog, work, intake, recovery, startup,
                  requests, steps, ending, log, stopping)
    for forget in (pending.forget, work.forget, watchdog.forget, recovery.forget, parts.say_removed):
        table.watch_removals(forget)
    for kind, route in core_routes(parts).items():
        intake.register(kind, route)
    return parts


def lines_of(name: str, level: int = logging.DEBUG) -> tuple[logging.Logger, list[str]]:
    """A logger of its own for one test, and the lines it gets (``level`` and above)."""
    lines: list[str] = []
    log = logging.getLogger(name)
    log.setLevel(level)
    log.propagate = False
    log.handlers.clear()
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    return log, lines
