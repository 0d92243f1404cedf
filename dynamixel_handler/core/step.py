"""One loop step in four phases: prepare, send (writes then reads), complete, finish."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from .. import units
from ..bus import ServoBus
from ..bus.ops import Ping
from ..servo import error_state
from ..servo.groups import GROUP_ITEMS, PRESENT
from ..servo.table import ServoTable
from ..settings import LogSettings
from .deferred import Deferred
from .e_stop import EStop
from .intake import Intake
from .led_status import LedStatus
from .pacing import Pacing
from .read_plan import ReadPlan
from .recovery import Recovery
from .servo_io import Log
from .startup import Startup
from .state import RECHECK_LOOPS, StepReport
from .watchdog import Watchdog
from .write_batch import WriteBatch

__all__ = ["RECHECK_LOOPS", "Step", "StepSettings", "Stepped"]


@dataclass(frozen=True)
class StepSettings:
    recheck_loops: int = RECHECK_LOOPS      # loops between pings of a silent servo (state.recheck_loops)
    logs: LogSettings = LogSettings()       # the read logs: values, silent servos, hardware errors


@dataclass(frozen=True)
class Stepped:
    """The parts a loop step drives, in the order of a step: requests and start-up work first,
    then pacing, writes, reads, recovery of silent servos, the watchdog, the E-stop's watch of
    hardware errors, the LEDs."""

    intake: Intake
    startup: Startup
    work: Deferred
    pacing: Pacing
    writes: WriteBatch
    reads: ReadPlan
    recovery: Recovery
    watchdog: Watchdog
    e_stop: EStop
    leds: LedStatus


class Step:
    """The loop step and its phases, over the parts that do the work; the read logs."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, parts: Stepped, settings: StepSettings) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.reads = parts.reads
        self.writes = parts.writes
        self.pacing = parts.pacing
        self.watchdog = parts.watchdog
        self.recovery = parts.recovery
        self.work = parts.work
        self.intake = parts.intake
        self.startup = parts.startup
        self.e_stop = parts.e_stop
        self.leds = parts.leds
        self.settings = settings
        self.loop_count = 0
        self._reported_errors: dict[int, tuple[int, str | None]] = {}

    def step(self) -> StepReport:
        """One whole loop: queued operations, pending writes, the reads due, bookkeeping."""
        report = self.begin_step()
        self.send_step(report)
        self.finish_step(report)
        return report

    # A step in four phases, so that a caller can overlap one loop's reads on the wire with work
    # that needs no bus (the node takes the next commands and publishes the previous states then):
    #   begin_step     reconnect, watchdog arming, queued operations (``prepare``)
    #   send_step      the pending writes (send_writes), then the reads due (send_reads); the last
    #                  read is left on the wire
    #   complete_step  its replies gathered, Fast Sync Read fallback, pings of silent servos, ping state
    #   finish_step    replies stored in the table, read logs, tripped watchdogs re-armed
    # Any bus transaction in between first waits for the read on the wire (``ServoBus``).
    def begin_step(self) -> StepReport:
        report = StepReport(loop=self.loop_count, phase=1)
        self.prepare(report)
        return report

    def prepare(self, report: StepReport) -> None:
        """Reopen a vanished device, arm watchdogs, run the queued requests (commands). Called
        by ``begin_step``, and again before ``send_step`` for commands that came meanwhile."""
        if self.recovery.device_gone:
            self.recovery.reconnect(report)
        if self.recovery.set_up_due:  # silent after a reconnect, answering now: set up as at start-up
            self.recovery.set_up_returned()
        if self.recovery.back_due:  # a servo answers again: set up again if it lost its power meanwhile
            self.recovery.look_at_returned()
        self.watchdog.arm_waiting()
        if self.work.waiting:
            for what, request in self.work.run_deferred():
                self.intake.run(request, what)
        self.intake.run_queued()
        if self.startup.membership:  # add_id / remove_id asked for by these requests: once each
            self.intake.guarded("add_id / remove_id", self._apply_membership)

    def _apply_membership(self) -> None:
        self.startup.apply_membership()

    def apply_now(self) -> None:
        """Between loops: run the queued operations and write what they left pending at once."""
        report = StepReport(loop=self.loop_count)
        self.prepare(report)
        self.writes.send()

    def send_step(self, report: StepReport) -> None:
        self.send_writes(report)
        self.send_reads(report)

    def send_writes(self, report: StepReport) -> None:
        """The first half of ``send_step``: what is pending goes on the wire."""
        self.writes.send()

    def encode_writes(self) -> None:
        """The goal packets of what is pending built ahead (sent by ``send_writes``): while the
        last loop's read is still on the wire."""
        self.writes.encode_writes()

    def await_replies(self, report: StepReport) -> None:
        """Wait until the replies of ``report``'s reads are in (``complete_step`` does the rest)."""
        for _, pending, _ in report.reads:
            pending.result()

    def send_reads(self, report: StepReport) -> None:
        """The second half of ``send_step``: the reads due; the last one is left on the wire."""
        report.phase = 2
        self.loop_count = report.loop + 1  # a loop that failed before its reads keeps its number
        report.read_s = -time.perf_counter()
        report.stamp = time.time()
        report.seq = self.table.seq
        if not len(self.table):
            return
        _, present, groups, items = self.reads.due(report.loop)
        report.present, report.groups = set(present), set(groups)
        live = self.table.ping.copy()
        if items:
            for read in self.reads.plan(items, live):
                report.reads.append([read, self.bus.start_sync_read(read.address, read.length, read.ids, read.fast,
                                                                    protocol=read.protocol), None])
            self.pacing.note_reads_sent()
        # servos that stopped answering are pinged now and then, not read every loop
        if report.loop % self.settings.recheck_loops == 0:
            report.recheck = [self.table.ids[pos] for pos in np.flatnonzero(~live)]

    @property
    def reply_eta(self) -> float | None:
        """``time.monotonic()`` by which the read left on the wire should be answered (None: none is)."""
        return self.bus.inflight_eta

    def complete_step(self, report: StepReport) -> None:
        if report.phase >= 3:
            return
        report.phase = 3
        table = self.table
        index = table.index
        addressed = np.zeros(len(table), dtype=bool)
        answered = np.zeros(len(table), dtype=bool)

        def mark(flags: np.ndarray, ids: Iterable[int]) -> None:
            # an operation may have removed one meanwhile
            positions = [pos for pos in map(index.get, ids) if pos is not None]
            if positions:
                flags[positions] = True

        for entry in report.reads:
            read = entry[0]
            entry[2] = data = self.reads.gather(read, entry[1].result())
            positions = table.positions(read.ids)
            addressed[positions] = True
            if len(data) == len(read.ids):  # every servo answered (the usual loop)
                answered[positions] = True
            else:
                mark(answered, data)
        for dxl_id in report.recheck:
            mark(addressed, [dxl_id])
            if dxl_id in index and self.bus.execute(Ping(dxl_id, 0, protocol=table.model(dxl_id).protocol)).value is not None:
                mark(answered, [dxl_id])
        report.silent = [table.ids[pos] for pos in np.flatnonzero(addressed & ~answered)]
        self.recovery.update_ping(addressed, answered)
        report.read_s += time.perf_counter()

    def finish_step(self, report: StepReport) -> None:
        if report.phase >= 4:
            return
        self.complete_step(report)
        report.phase = 4
        for read, pending, data in report.reads:
            if data:
                self.reads.store(read, data, report.stamp, report.seq)
            for dxl_id, error in pending.errors.items():  # Protocol 1.0 reads: the state in each status
                if dxl_id in self.table:
                    error_state.keep_status_error(self.table, dxl_id, error)
        if len(self.table):
            self._log_reads(report, report.silent)
        self.e_stop.watch()  # hold_all: a new hardware error engages the E-stop
        self.leds.show()  # led_status: the LEDs of the servos whose state changed
        if "extra_dynamic" in report.groups:
            self.watchdog.check_later()  # at the next step, after this loop's states are out

    def _log_reads(self, report: StepReport, silent: list[int]) -> None:
        """verbose/read_<group>.{raw,err} and verbose/read_hardware_error, max_log_width IDs a line."""
        groups = set(report.groups) | ({"present"} if report.present else set())
        for group in sorted(groups):
            if group != "error":
                self._log_group(group, report, silent)
        if "error" in report.groups and self.settings.logs.hardware_error:
            self._log_hardware_errors()

    def _log_group(self, group: str, report: StepReport, silent: list[int]) -> None:
        logs, table = self.settings.logs, self.table
        key = "extra" if group.startswith("extra") else group
        if key in logs.reads_err and silent:
            self.log.warning(f"read {group}: no answer from IDs {silent}")
        if key not in logs.reads_raw:
            return
        items = [PRESENT[k][0] for k in sorted(report.present)] if group == "present" else list(GROUP_ITEMS[group])
        for item in items:
            if table.known(item).any():
                self.log.info(f"read {group} {item}: " + _rows(table.ids, table.pulses(item), logs.max_width))

    def _log_hardware_errors(self) -> None:
        """One line per servo whose hardware error bits (or error code, named) changed to non-zero."""
        table = self.table
        bits = error_state.hardware_bits(table)
        codes = error_state.codes_by_position(table)  # Y: the error code by name
        flags = units.decode_hardware_error(bits)
        failing = error_state.in_error(table)
        errors = {table.ids[pos]: (int(bits[pos]), codes.get(pos)) for pos in {int(i) for i in np.flatnonzero(bits)} | set(codes)}
        for pos in sorted(table.index[i] for i in errors):
            dxl_id = table.ids[pos]
            if self._reported_errors.get(dxl_id) != errors[dxl_id]:
                causes = ", ".join(name for name, f in flags.items() if f[pos])
                what = codes.get(pos) or f"0x{int(bits[pos]):02X}"
                label = (causes or what) if pos in codes else causes  # a Y code without a bit: by name
                if not failing[pos]:  # a warning code (Y battery warning): the servo runs on
                    self.log.warning(f"ID {dxl_id}: {what}")
                    continue
                self.log.error(f"ID {dxl_id}: hardware error {label} ({what}): "
                               "clear it with the shortcut clear_error (CE)")
        self._reported_errors = errors


def _rows(ids: Sequence[int], values: np.ndarray, width: int) -> str:
    pairs = [f"{i}={v}" for i, v in zip(ids, values.tolist())]
    return "\n  ".join(", ".join(pairs[k:k + width]) for k in range(0, len(pairs), max(1, width)))
