"""The core's parts of one bus, built and wired in one place: each given the bus, table, pending
writes and log it needs, its slice of the typed settings and the other parts it calls; removals of
servos watched by the parts that keep something per servo; each core request type routed to the
part that does it. The ``Handler`` is a front over one ``Parts``; a unit test builds the same
``Parts`` over a fake bus, so the part it tests is wired as the one the node runs."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..bus import ServoBus
from ..servo.table import PendingWrites, ServoTable
from ..settings import LoopSettings, Settings, TermSettings
from .deferred import Deferred
from .e_stop import EStop
from .group_io import GroupIO
from .intake import Intake
from .led_status import LedStatus
from .pacing import Pacing
from .read_plan import ReadPlan, ReadSettings, every
from .recovery import Recovery
from .request_types import (
    AddServo,
    Answer,
    CancelDeferred,
    ChangeMode,
    ClearError,
    DeferModeChange,
    EngageStop,
    Reboot,
    ReleaseStop,
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
from .requests import Requests
from .servo_io import Log, ServoIO
from .shutdown import Shutdown
from .startup import Startup, StartupSettings
from .state import recheck_loops
from .step import Step, Stepped, StepSettings
from .watchdog import Watchdog, WatchdogSettings
from .write_batch import WriteBatch

__all__ = ["PART_NAMES", "PartSettings", "Parts", "build_parts", "core_routes", "part_settings"]

#: the parts, by the names the ``Handler`` gives them too
PART_NAMES = ("bus", "table", "pending", "io", "group", "pacing", "reads", "writes", "watchdog", "work", "intake",
              "recovery", "startup", "requests", "steps", "ending", "e_stop", "leds")


@dataclass(frozen=True)
class PartSettings:
    """What each part reads of the settings."""

    reads: ReadSettings
    watchdog: WatchdogSettings
    loop: LoopSettings          # Recovery and Requests: the intervals, the removal count
    startup: StartupSettings
    step: StepSettings
    term: TermSettings          # Shutdown
    split_write: bool           # WriteBatch
    on_hardware_error: str      # EStop
    led_status: bool            # LedStatus


def part_settings(s: Settings) -> PartSettings:
    """Each part's slice of the typed settings (the one place that hands them out)."""
    return PartSettings(
        reads=ReadSettings(s.ratios, s.method.fast_read, s.method.split_read),
        watchdog=WatchdogSettings(float(s.loop.rate_hz), every(s.ratios), float(s.start.bus_watchdog_ms),
                                  s.term.servo_auto_stop),
        loop=s.loop,
        startup=StartupSettings(s.scan, s.start, s.loop.debug, s.servos),
        step=StepSettings(recheck_loops(s.loop.rate_hz), s.logs),
        term=s.term,
        split_write=s.method.split_write,
        on_hardware_error=s.safety.on_hardware_error,
        led_status=s.safety.led_status,
    )


@dataclass
class Parts:
    """Every part of one bus."""

    bus: ServoBus
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
    e_stop: EStop
    leds: LedStatus

    def apply(self, settings: Settings) -> None:
        """New settings (replaced as a whole): each part gets its new slice."""
        s = part_settings(settings)
        self.reads.settings, self.watchdog.settings, self.startup.settings = s.reads, s.watchdog, s.startup
        self.recovery.settings = self.requests.settings = s.loop
        self.steps.settings, self.ending.settings = s.step, s.term
        self.writes.split_write = s.split_write
        self.e_stop.on_hardware_error = s.on_hardware_error
        self.leds.enabled = s.led_status

    def set_log(self, log: Log) -> None:
        """Every part logs to ``log`` from now on."""
        for part in (self.io, self.group, self.reads, self.writes, self.watchdog, self.work, self.intake,
                     self.recovery, self.startup, self.requests, self.steps, self.ending, self.e_stop):
            part.log = log


def build_parts(bus: ServoBus, settings: Settings, log: Log, interrupted: Callable[[], bool],
                tripped_once: bool = True) -> Parts:
    """The parts over ``bus``; ``interrupted`` is true once the node is asked to exit (start-up
    stops between two servos, mode changes not yet made are dropped). ``tripped_once`` False:
    goals look for tripped bus watchdogs servo by servo (``Watchdog``)."""
    s = part_settings(settings)
    table, pending = ServoTable(), PendingWrites()

    def set_up(dxl_id: int) -> None:  # Recovery sets a servo up again (after a reconnect) as Startup does
        startup.setup_servo(dxl_id)

    io = ServoIO(bus, table, log)
    group = GroupIO(bus, table, log)
    pacing = Pacing(bus, table, interrupted)
    reads = ReadPlan(bus, table, log, pacing, s.reads)
    writes = WriteBatch(bus, table, pending, log, s.split_write)
    watchdog = Watchdog(table, log, io, group, s.watchdog, tripped_once)
    work = Deferred(table, log, io)
    e_stop = EStop(table, pending, io, group, work, log, s.on_hardware_error)
    intake = Intake(log, e_stop.refusal)
    leds = LedStatus(table, pending, e_stop.engaged_why, s.led_status)
    recovery = Recovery(bus, table, log, io, watchdog, s.loop, set_up)
    startup = Startup(bus, table, log, io, work, recovery, watchdog, s.startup, interrupted)
    requests = Requests(table, pending, log, io, watchdog, pacing, work, recovery, s.loop)
    steps = Step(bus, table, log, Stepped(intake, startup, work, pacing, writes, reads, recovery, watchdog, e_stop,
                                          leds), s.step)
    ending = Shutdown(bus, table, log, io, group, s.term)
    parts = Parts(bus, table, pending, io, group, pacing, reads, writes, watchdog, work, intake, recovery, startup,
                  requests, steps, ending, e_stop, leds)
    # a servo removed (a remove_id request, silent too long, the lifecycle's cleanup): each part
    # that keeps something per servo forgets it
    for forget in (pending.forget, work.forget, watchdog.forget, recovery.forget, e_stop.forget, leds.forget):
        table.watch_removals(forget)
    # the servos block's RAM items come back after what resets them
    recovery.put_back = requests.put_back = startup.kept.put_back
    recovery.file_sets = startup.kept.sets
    for kind, route in core_routes(parts).items():
        intake.register(kind, route)
    return parts


def core_routes(p: Parts) -> dict[type, Callable[[Any], Answer | None]]:
    """The table from each core request type to the part that does it."""
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
        EngageStop: p.e_stop.engage,
        ReleaseStop: p.e_stop.release,
    }
