"""Reply gathering on one serial line (``Receiver``): how long to wait, status packets collected one
per expected ID or one fast-read reply split by position, the status error bytes noted, and a
device that stops working mid-run."""
from __future__ import annotations

import time
from typing import Any, Callable

import serial

from ..protocol import host as p
from ..protocol.framers import PROTOCOL2, Framer
from .group_read import reply_bytes
from .line import Line
from .stats import BusStats


class Receiver:
    """The receiving side of one serial line, and the line's timing: when what was sent is off the
    wire (``wire_free_at``) and how late replies come (``reply_lag_s``)."""

    def __init__(self, port: Line, stats: BusStats, log: Callable[[str, str], None],
                 timeout_margin_ms: float, verbose: bool) -> None:
        self.port = port
        self.stats = stats
        self.log = log
        self.timeout_margin_ms = timeout_margin_ms
        self.verbose = verbose
        #: the reply wait (ms) computed for the latest transaction
        self.last_timeout_ms = 0.0
        #: how much later than their wire time replies arrive (learnt, seconds)
        self.reply_lag_s = 0.0
        #: ``time.monotonic()`` when the line is free of what was sent (packets queue behind each other)
        self.wire_free_at = 0.0

    def reply_timeout_ms(self, tx_bytes: int, rx_bytes: int) -> float:
        """How long to wait for ``rx_bytes`` of reply after sending ``tx_bytes``.

        Two latency-timer periods (the adapter buffers each direction), the wire time of
        both packets and a margin for the servo's return delay and host scheduling.
        """
        return (2.0 * self.port.effective_latency_ms + (tx_bytes + rx_bytes) * self.port.tx_ms_per_byte
                + self.timeout_margin_ms)

    def gather(self, expected: list[tuple[int, int]], tx_bytes: int, fast: bool,
               sent_at: float | None = None, *, framer: Framer) -> dict[int, Any] | None:
        """The replies to a packet sent at ``sent_at`` (default: just now) in ``framer``'s protocol;
        None if the port is unusable."""
        if not expected:
            return {}
        port = self.port
        sent_at = time.monotonic() if sent_at is None else sent_at
        # a packet queued behind one still on the wire (a sync write just before) starts later:
        # its reply timeout counts from when it goes out, not from when it was handed over
        sent_at = max(sent_at, self.wire_free_at - tx_bytes * port.tx_ms_per_byte / 1000.0)
        # when the last reply byte should be in: the line is free of what was sent at wire_free_at
        # (no other packet goes out while a read is in flight), then the replies and the usual lag
        due = (self.wire_free_at + reply_bytes(expected, fast, framer.status_overhead) * port.tx_ms_per_byte / 1000.0
               + self.reply_lag_s)
        try:
            if fast:
                return self._receive_fast(expected, tx_bytes, sent_at, due)
            return self._receive(expected, tx_bytes, sent_at, due, framer=framer)
        except (OSError, serial.SerialException) as exc:
            self.lose(exc)
            return None
        finally:
            # what was sent before has been answered (or timed out): the line is free now
            self.wire_free_at = min(self.wire_free_at, time.monotonic())

    def _receive(self, expected: list[tuple[int, int]], tx_bytes: int, sent_at: float,
                 due: float | None = None, *, framer: Framer) -> dict[int, Any]:
        """Collect stuffed status packets, one per expected ID, each with its own wait.

        The first reply gets the full timeout (our packet's wire time included); each
        reply that arrives restarts the wait for the next, so one silent servo costs
        one reply wait and the others are still collected.
        """
        pending = dict(expected)
        overhead = framer.status_overhead
        largest = overhead + max(size for _, size in expected)
        first_ms = self.reply_timeout_ms(tx_bytes, largest)
        gap_s = self.reply_timeout_ms(0, largest) / 1000.0
        self.last_timeout_ms = first_ms
        deadline = sent_at + first_ms / 1000.0
        stream = framer.statuses()
        got: dict[int, Any] = {}
        stats = self.stats
        while pending:
            data = self.port.read_until(deadline, sum(overhead + n for n in pending.values())
                                        - stream.pending_bytes, due)
            if not data:
                break
            stats.bytes_rx += len(data)
            answered = False
            for status in stream.feed(data):
                size = pending.get(status.dxl_id)
                if size is None or (len(status.params) != size and not status.refused):
                    # a late reply of an earlier transaction, or not ours: never take it as the answer
                    stats.discarded_bytes += overhead + len(status.params)
                    continue
                del pending[status.dxl_id]
                got[status.dxl_id] = status
                self.note_status(status, framer=framer)
                answered = True
            if answered:  # each reply restarts the wait for the next
                deadline = max(deadline, time.monotonic() + gap_s)
        if pending:
            stats.timeouts += 1
        stats.crc_errors += stream.crc_errors
        stats.discarded_bytes += stream.discarded_bytes
        return got

    def _receive_fast(self, expected: list[tuple[int, int]], tx_bytes: int, sent_at: float,
                      due: float | None = None) -> dict[int, p.Status]:
        """Collect the single unstuffed fast-read reply and split it by position."""
        reply = p.FastReply(expected)
        total = 8 + sum(size + 4 for _, size in expected)
        first_ms = self.reply_timeout_ms(tx_bytes, total)
        gap_s = self.reply_timeout_ms(0, 4 + max(size for _, size in expected)) / 1000.0
        self.last_timeout_ms = first_ms
        deadline = sent_at + first_ms / 1000.0
        while not reply.complete:
            data = self.port.read_until(deadline, total - reply.received_bytes, due)
            if not data:
                break
            self.stats.bytes_rx += len(data)
            reply.feed(data)
            deadline = max(deadline, time.monotonic() + gap_s)
        got = reply.segments()
        for status in got.values():
            self.note_status(status, framer=PROTOCOL2)  # Fast Sync Read: Protocol 2.0 only
        if not reply.complete:
            self.stats.timeouts += 1
        self.stats.crc_errors += reply.crc_errors
        self.stats.discarded_bytes += reply.discarded_bytes
        return got

    def note_status(self, status: Any, *, framer: Framer) -> None:
        if status.refused:
            self.stats.servo_errors += 1
            if self.verbose:
                self.log("warning", f"ID {status.dxl_id} refused: {framer.error_text(status.error)}")

    def lose(self, exc: BaseException) -> None:
        """The device went away mid-run: fail fast from now on until reopen()."""
        port = self.port
        if not port.lost:
            port.lost = True
            self.stats.disconnects += 1
            self.log("error", f"{port.device} stopped working ({exc}): the port hung up (adapter unplugged, or "
                              "another process reading it?); transactions fail until reopen() succeeds")
        port.close()
