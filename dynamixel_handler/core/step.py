"""One loop step in four phases: prepare, send (writes then reads), complete, finish."""
from __future__ import annotations

import time
from typing import Iterable, Sequence

import numpy as np

from .. import units
from ..groups import GROUP_ITEMS, PRESENT
from .deferred import Deferred
from .group_io import GroupIO
from .read_plan import _Read
from .recovery import Recovery
from .state import RECHECK_LOOPS, StepReport
from .write_batch import WriteBatch

__all__ = ["RECHECK_LOOPS", "Step"]


class Step(Recovery, Deferred, WriteBatch, GroupIO):
    """The loop step and its phases; the read logs."""

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
        """Reopen a vanished device, arm watchdogs, run the queued operations (commands). Called
        by ``begin_step``, and again before ``send_step`` for commands that came meanwhile."""
        if self._had_device and not self.bus.is_open:
            self._reconnect(report)
        if self._to_arm:
            self._arm_watchdogs(sorted(i for i in self._to_arm if i in self.table))
            self._to_arm.clear()
        if self._check_watchdogs:
            self._check_watchdogs = False
            self.check_watchdogs()
        if self.deferred or self._eeprom_deferred:
            self._run_deferred()
        self._run_ops()

    def apply_now(self) -> None:
        """Between loops: run the queued operations and write what they left pending at once."""
        report = StepReport(loop=self.loop_count)
        self.prepare(report)
        self._send_writes()

    def _arm_watchdogs(self, ids: list[int]) -> None:
        """``arm_watchdog`` for many servos at once: the automatic watchdogs in two sync writes
        (0 first where one is set: clears a trip, allows a new value), so that arming twenty servos
        on a slow bus does not leave the first ones armed unaddressed while the last ones are
        written; a watchdog a command set, servo by servo."""
        auto = [i for i in ids if i not in self.watchdog_user and self.table.model(i).has("bus_watchdog")]
        for dxl_id in ids:
            if dxl_id in self.watchdog_user:
                self.arm_watchdog(dxl_id)
        pulses = {i: self.watchdog_for(i) for i in auto}
        self.write_group("bus_watchdog", {i: 0 for i in auto if self.table.value("bus_watchdog", i) != 0}, "watchdog")
        self.write_group("bus_watchdog", {i: p for i, p in pulses.items() if p}, "watchdog")

    def send_step(self, report: StepReport) -> None:
        self.send_writes(report)
        self.send_reads(report)

    def send_writes(self, report: StepReport) -> None:
        """The first half of ``send_step``: what is pending goes on the wire."""
        self._send_writes()

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
        _, present, groups, items = self._due(report.loop)
        report.present, report.groups = set(present), set(groups)
        live = self.table.ping.copy()
        if items:
            for read in self._plan(items, live):
                report.reads.append([read, self.bus.start_sync_read(read.address, read.length, read.ids, fast=read.fast), None])
            self.note_reads_sent()
        # servos that stopped answering are pinged now and then, not read every loop
        if report.loop % self.recheck_loops == 0:
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
            entry[2] = data = self._gather(read, entry[1].result())
            positions = table.positions(read.ids)
            addressed[positions] = True
            if len(data) == len(read.ids):  # every servo answered (the usual loop)
                answered[positions] = True
            else:
                mark(answered, data)
        for dxl_id in report.recheck:
            mark(addressed, [dxl_id])
            if dxl_id in index and self.bus.ping(dxl_id, retries=0) is not None:
                mark(answered, [dxl_id])
        report.silent = [table.ids[pos] for pos in np.flatnonzero(addressed & ~answered)]
        self._update_ping(addressed, answered)
        report.read_s += time.perf_counter()

    def _gather(self, read: _Read, data: dict[int, bytes]) -> dict[int, bytes]:
        """One read's replies, completed by a plain Sync Read where a Fast Sync Read stopped short."""
        if read.fast and self._fast_misses:
            for dxl_id in data:  # answered the fast read: a miss before was not its firmware
                self._fast_misses.pop(dxl_id, None)
        if read.fast and len(data) < len(read.ids):
            data = self._read_plain(read, data)
        return data

    def finish_step(self, report: StepReport) -> None:
        if report.phase >= 4:
            return
        self.complete_step(report)
        report.phase = 4
        for read, _, data in report.reads:
            if data:
                self._store(read, data, report.stamp, report.seq)
        if len(self.table):
            self._log_reads(report, report.silent)
        if "extra_dynamic" in report.groups:
            self._check_watchdogs = True  # at the next step, after this loop's states are out

    def _log_reads(self, report: StepReport, silent: list[int]) -> None:
        """verbose/read_<group>.{raw,err} and verbose/read_hardware_error, max_log_width IDs a line."""
        groups = set(report.groups) | ({"present"} if report.present else set())
        for group in sorted(groups):
            if group != "error":
                self._log_group(group, report, silent)
        if "error" in report.groups and self.config["verbose/read_hardware_error"]:
            self._log_hardware_errors()

    def _log_group(self, group: str, report: StepReport, silent: list[int]) -> None:
        cfg, table = self.config, self.table
        key = "extra" if group.startswith("extra") else group
        if cfg.values.get(f"verbose/read_{key}.err") and silent:
            self.log.warning(f"read {group}: no answer from IDs {silent}")
        if not cfg.values.get(f"verbose/read_{key}.raw"):
            return
        items = [PRESENT[k][0] for k in sorted(report.present)] if group == "present" else list(GROUP_ITEMS[group])
        for item in items:
            if table.known(item).any():
                self.log.info(f"read {group} {item}: " + _rows(table.ids, table.pulses(item), cfg["max_log_width"]))

    def _log_hardware_errors(self) -> None:
        """One line per servo whose hardware error bits changed to non-zero."""
        table = self.table
        bits = np.where(table.known("hardware_error_status"), table.pulses("hardware_error_status"), 0)
        flags = units.decode_hardware_error(bits)
        for pos in np.flatnonzero(bits):
            dxl_id = table.ids[pos]
            if self._reported_errors.get(dxl_id) != bits[pos]:
                causes = [name for name, f in flags.items() if f[pos]]
                self.log.error(f"ID {dxl_id}: hardware error {', '.join(causes)} (0x{int(bits[pos]):02X}): "
                               "clear it with the shortcut clear_error (CE)")
        self._reported_errors = {table.ids[pos]: bits[pos] for pos in np.flatnonzero(bits)}


def _rows(ids: Sequence[int], values: np.ndarray, width: int) -> str:
    pairs = [f"{i}={v}" for i, v in zip(ids, values.tolist())]
    return "\n  ".join(", ".join(pairs[k:k + width]) for k in range(0, len(pairs), max(1, width)))
