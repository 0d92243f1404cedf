"""The core's parts of one bus, built and wired in one place: each given the bus, table, pending
writes and log it needs, its slice of the typed settings and the other parts it calls; removals of
servos watched by the parts that keep something per servo; the core's queued requests (the
E-stop's) routed to it; the command side's typed surface (``calls.CoreCalls``). The ``Handler`` is
a front over one ``Parts``; a unit test builds the same ``Parts`` over a fake bus, so the part it
tests is wired as the one the node runs."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..bus import ServoBus
from ..servo.settings import ServoSetting
from ..servo.table import PendingWrites, ServoTable
from ..settings import LoopSettings, Settings, TermSettings
from .calls import CoreCalls
from .deferred import Deferred
from .e_stop import EStop
from .group_io import GroupIO
from .intake import Intake
from .kept_settings import KeptSettings
from .led_status import LedStatus
from .pacing import Pacing
from .read_plan import ReadPlan, ReadSettings, every
from .reboots import Reboots
from .recovery import Recovery
from .requests import Requests
from .servo_io import Log, ServoIO
from .servo_setup import ServoSetup, SetupSettings
from .shutdown import Shutdown
from .startup import Startup, StartupSettings
from .state import recheck_loops
from .step import Step, Stepped, StepSettings
from .watchdog import Watchdog, WatchdogSettings
from .write_batch import WriteBatch

__all__ = ["PART_NAMES", "PartSettings", "Parts", "build_parts", "part_settings"]

#: the parts, by the names the ``Handler`` gives them too
PART_NAMES = ("bus", "table", "pending", "io", "group", "pacing", "reads", "writes", "watchdog", "work", "intake",
              "recovery", "startup", "requests", "steps", "ending", "e_stop", "leds", "core",
              "setup", "reboots")


@dataclass(frozen=True)
class PartSettings:
    """What each part reads of the settings."""

    reads: ReadSettings
    watchdog: WatchdogSettings
    loop: LoopSettings          # Recovery and Requests: the intervals, the removal count
    startup: StartupSettings
    setup: SetupSettings        # ServoSetup
    servos: tuple[ServoSetting, ...]  # KeptSettings: the servos block
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
        startup=StartupSettings(s.scan, s.loop.debug),
        setup=SetupSettings.of(s.scan, s.start),
        servos=s.servos,
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
    core: CoreCalls
    setup: ServoSetup
    reboots: Reboots

    def apply(self, settings: Settings) -> None:
        """New settings (replaced as a whole): each part gets its new slice."""
        s = part_settings(settings)
        self.reads.settings, self.watchdog.settings, self.startup.settings = s.reads, s.watchdog, s.startup
        self.setup.settings, self.setup.kept.servos = s.setup, s.servos
        self.recovery.settings = self.requests.settings = self.reboots.settings = s.loop
        self.steps.settings, self.ending.settings = s.step, s.term
        self.writes.split_write = s.split_write
        self.e_stop.on_hardware_error = s.on_hardware_error
        self.leds.enabled = s.led_status

    def set_log(self, log: Log) -> None:
        """Every part logs to ``log`` from now on."""
        for part in (self.io, self.group, self.reads, self.writes, self.watchdog, self.work, self.intake,
                     self.recovery, self.startup, self.requests, self.steps, self.ending, self.e_stop, self.setup,
                     self.reboots):
            part.log = log


def build_parts(bus: ServoBus, settings: Settings, log: Log, interrupted: Callable[[], bool],
                tripped_once: bool = True) -> Parts:
    """The parts over ``bus``; ``interrupted`` is true once the node is asked to exit (start-up
    stops between two servos, mode changes not yet made are dropped). ``tripped_once`` False:
    goals look for tripped bus watchdogs servo by servo (``Watchdog``)."""
    s = part_settings(settings)
    table, pending = ServoTable(), PendingWrites()

    io = ServoIO(bus, table, log)
    group = GroupIO(bus, table, log)
    pacing = Pacing(bus, table, interrupted)
    reads = ReadPlan(bus, table, log, pacing, s.reads)
    writes = WriteBatch(bus, table, pending, log, s.split_write)
    watchdog = Watchdog(table, log, io, group, s.watchdog, tripped_once)
    work = Deferred(table, log, io)
    e_stop = EStop(table, pending, io, group, work, log, s.on_hardware_error)
    intake = Intake(log)
    leds = LedStatus(table, pending, e_stop.engaged_why, s.led_status)
    # the servos block: checked after the scan, applied at each set-up, put back after what resets RAM
    kept = KeptSettings(table, io, work, watchdog, s.servos, lambda level, msg: log.log(level, msg))
    reboots = Reboots(bus, table, log, io, watchdog, kept, s.loop)
    setup = ServoSetup(table, log, io, work, watchdog, kept, reboots, s.setup)
    recovery = Recovery(bus, table, log, io, watchdog, s.loop, setup)
    startup = Startup(bus, table, log, setup, s.startup, interrupted)
    requests = Requests(table, pending, log, io, watchdog, pacing, work, reboots, kept, s.loop)
    steps = Step(bus, table, log, Stepped(intake, startup, work, pacing, writes, reads, recovery, watchdog, e_stop,
                                          leds), s.step)
    ending = Shutdown(bus, table, log, io, group, s.term)
    core = CoreCalls(table, io, work, requests, reboots, startup, watchdog, e_stop, setup)
    parts = Parts(bus, table, pending, io, group, pacing, reads, writes, watchdog, work, intake, recovery, startup,
                  requests, steps, ending, e_stop, leds, core, setup, reboots)
    # a servo removed (a remove_id request, silent too long, the lifecycle's cleanup): each part
    # that keeps something per servo forgets it
    for forget in (pending.forget, work.forget, watchdog.forget, recovery.forget, e_stop.forget, leds.forget):
        table.watch_removals(forget)
    intake.attach(e_stop)  # the core's own queued requests; the command side's parts are attached by who builds them
    return parts

