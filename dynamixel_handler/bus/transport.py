"""The wire under ``DynamixelBus``: one transaction at a time, retries, reply gathering, the
read left in flight, counters. Everything above it (reads, writes, single-servo instructions)
goes through ``Transport._transaction`` or ``Transport._start_group_read``, so a read in flight is
always gathered before anything else is sent and no reply is taken for another transaction's.
"""
from __future__ import annotations

import logging
import operator
import threading
import time
from contextlib import contextmanager
from typing import Iterable, Iterator

import serial

from ..protocol import host as p
from .errors import BusError
from .port import SerialPort
from .stats import BusStats, Outcome

#: cap of the learnt reply lag [s]
_MAX_REPLY_LAG_S = 0.02


class GroupRead:
    """A sync read on the wire: ``result()`` waits for its replies (once; later calls return the
    same dict). ``eta`` is when they should be in (``time.monotonic()``)."""

    def __init__(self, bus: "Transport | None", packet: bytes, expected: list[tuple[int, int]], fast: bool,
                 what: str) -> None:
        self._bus = bus
        self.packet = packet
        self.expected = expected
        self.fast = fast
        self.what = what
        self.sent = False
        self.reply_bytes = 0
        self.started = time.monotonic()
        self.eta = self.started
        self._data: dict[int, bytes] | None = None

    @classmethod
    def finished(cls, data: dict[int, bytes]) -> GroupRead:
        read = cls(None, b"", [], False, "")
        read._data = data
        return read

    @property
    def done(self) -> bool:
        return self._data is not None

    def finish(self, data: dict[int, bytes]) -> None:
        self._data = data

    def result(self) -> dict[int, bytes]:
        if self._data is None:
            self._bus._finish_group_read(self)
        return self._data  # type: ignore[return-value]


class Transport:
    """One Protocol 2.0 serial line: the port, one transaction at a time, retries and counters.

    Reads return ``None``/missing keys and writes return ``False`` on failure; they
    never raise for communication problems (a vanished device included), only
    :class:`BusError` from :meth:`open`/:meth:`reopen`/:meth:`set_baudrate` and
    ``ValueError`` for invalid arguments. A failed transaction is retried up to
    ``retry_num`` times, ``retry_interval_ms`` apart.
    """

    def __init__(self, device: str, baudrate: int = 57600, latency_timer_ms: float = 16.0,
                 retry_num: int = 5, retry_interval_ms: float = 4.0, verbose: bool = False,
                 logger=None, timeout_margin_ms: float = 2.0) -> None:
        if latency_timer_ms <= 0:
            raise ValueError(f"latency_timer_ms must be > 0, got {latency_timer_ms}")
        self.retry_num = max(0, int(retry_num))
        self.retry_interval_ms = max(0.0, float(retry_interval_ms))
        self.timeout_margin_ms = max(0.0, float(timeout_margin_ms))
        self.verbose = verbose
        self.stats = BusStats()
        #: status error byte last reported by each servo (0x80 = hardware error present)
        self.last_error_bytes: dict[int, int] = {}
        #: firmware version seen in ping replies
        self.firmware_versions: dict[int, int] = {}
        #: the reply wait (ms) computed for the latest transaction
        self.last_timeout_ms = 0.0
        #: human-readable reason of the latest failure ("" if none yet)
        self.last_failure = ""
        self._logger = logger if logger is not None else logging.getLogger("dynamixel_handler.bus")
        self._port = SerialPort(device, baudrate, latency_timer_ms, log=self._log)
        self._lock = threading.RLock()
        self._ever_opened = False
        self._inflight: GroupRead | None = None  # a sync read sent but not yet gathered
        self._wire_free_at = 0.0
        #: how much later than their wire time replies arrive (learnt, seconds)
        self.reply_lag_s = 0.0
        self._packets: dict[tuple, bytes] = {}  # sync read packets by (address, length, ids, fast)

    @property
    def device(self) -> str:
        return self._port.device

    @property
    def baudrate(self) -> int:
        return self._port.baudrate

    @property
    def latency_timer_ms(self) -> float:
        """Latency used in timeouts (the configured one, or the adapter's if it is longer)."""
        return self._port.effective_latency_ms

    @property
    def is_open(self) -> bool:
        """True while the port is open and the device has not vanished."""
        return self._port.is_open

    def open(self) -> None:
        """Open the device; BusError (what, why, what to do) if it is missing, busy, not a tty."""
        with self._lock:
            self._port.open()
            self._ever_opened = True

    def close(self) -> None:
        with self._lock:
            self._port.close()

    def reopen(self) -> None:
        """Close and open again, e.g. after the adapter was unplugged and plugged back."""
        with self._lock:
            self._port.close()
            self._port.lost = False
            self._port.open()
            self._ever_opened = True

    def set_baudrate(self, baudrate: int) -> None:
        with self._lock:
            self._port.set_baudrate(baudrate)

    def __enter__(self) -> "Transport":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def reply_timeout_ms(self, tx_bytes: int, rx_bytes: int) -> float:
        """How long to wait for ``rx_bytes`` of reply after sending ``tx_bytes``.

        Two latency-timer periods (the adapter buffers each direction), the wire time of
        both packets and a margin for the servo's return delay and host scheduling.
        """
        return (2.0 * self.latency_timer_ms + (tx_bytes + rx_bytes) * self._port.tx_ms_per_byte
                + self.timeout_margin_ms)

    def _finish_group_read(self, read: GroupRead) -> None:
        """Gather the replies of ``read`` (retrying the instruction when nobody answered)."""
        with self._lock:
            if read.done:
                return
            if self._inflight is read:
                self._inflight = None
            data: dict[int, bytes] = {}
            try:
                waited = read.sent and self._port.waiting() < read.reply_bytes
                replies = self._gather(read.expected, len(read.packet), read.fast, read.started) if read.sent else None
                if replies is not None and len(replies) == len(read.expected):
                    self._learn_lag(read, waited)
                for _ in range(self.retry_num):
                    if replies is None or replies:
                        break
                    self._pause_before_retry()
                    replies = self._exchange(read.packet, read.expected, read.fast)
                data = {i: s.params for i, s in (replies or {}).items() if not s.refused}
                if data:
                    Outcome(self).ok(len(data), len(read.expected))
                else:
                    Outcome(self).fail(f"{read.what}: no servo answered")
                missing = [i for i, _ in read.expected if i not in data]
                if missing and data and self.verbose:
                    self._log("warning", f"{read.what}: no valid reply from ID {missing}")
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - read.started
                read.finish({i: data[i] for i, _ in read.expected if i in data})

    def _learn_lag(self, read: GroupRead, waited: bool) -> None:
        """Track how much later than their wire time replies arrive (adapter latency, the servos'
        return delay, scheduling), so ``eta`` of the next read is right: from reads that were
        waited for; a reply that was already complete when asked for pulls the estimate down."""
        if waited:
            late = max(0.0, time.monotonic() - (read.eta - self.reply_lag_s))
            self.reply_lag_s += 0.2 * (min(late, _MAX_REPLY_LAG_S) - self.reply_lag_s)
        else:
            self.reply_lag_s *= 0.8

    def _settle(self) -> None:
        """End a read left in flight before anything else goes on the wire."""
        if self._inflight is not None:
            self._finish_group_read(self._inflight)

    @property
    def inflight_eta(self) -> float | None:
        """``time.monotonic()`` by which the replies of the read in flight should be in, or None."""
        read = self._inflight
        return read.eta if read is not None else None

    def _unicast(self, dxl_id: int, instruction: int, params: bytes, reply_params: int,
                 retries: int | None = None) -> p.Status | None:
        """Send to one servo and return its status; retried on silence, noise and servo CRC errors."""
        packet = p.build_instruction(dxl_id, instruction, params)
        attempts = 1 + (self.retry_num if retries is None else max(0, retries))
        status = None
        for attempt in range(attempts):
            if attempt:
                self._pause_before_retry()
            replies = self._exchange(packet, [(dxl_id, reply_params)], False)
            if replies is None:
                return None
            status = replies.get(dxl_id)
            if status is not None and (status.error & 0x7F) != 3:
                return status
        return status

    def _exchange(self, packet: bytes, expected: list[tuple[int, int]], fast: bool) -> dict[int, p.Status] | None:
        """Send ``packet`` and gather the expected replies; None if the port is unusable."""
        if not self._send_or_lose(packet):
            return None
        return self._gather(expected, len(packet), fast)

    def _gather(self, expected: list[tuple[int, int]], tx_bytes: int, fast: bool,
                sent_at: float | None = None) -> dict[int, p.Status] | None:
        """The replies to a packet sent at ``sent_at`` (default: just now); None if the port is unusable."""
        if not expected:
            return {}
        sent_at = time.monotonic() if sent_at is None else sent_at
        # when the last reply byte should be in: the line is free of what was sent at _wire_free_at
        # (no other packet goes out while a read is in flight), then the replies and the usual lag
        due = (self._wire_free_at + _reply_bytes(expected, fast) * self._port.tx_ms_per_byte / 1000.0
               + self.reply_lag_s)
        try:
            if fast:
                return self._receive_fast(expected, tx_bytes, sent_at, due)
            return self._receive(expected, tx_bytes, sent_at, due)
        except (OSError, serial.SerialException) as exc:
            self._lose(exc)
            return None
        finally:
            # what was sent before has been answered (or timed out): the line is free now
            self._wire_free_at = min(self._wire_free_at, time.monotonic())

    def _send_or_lose(self, packet: bytes) -> bool:
        if not self._ever_opened:
            raise BusError(f"{self.device} is not open: call open() first.")
        if not self._port.is_open:
            return False
        try:
            self.stats.discarded_bytes += self._port.discard_input()
            self._port.write(packet)
        except (OSError, serial.SerialException) as exc:
            self._lose(exc)
            return False
        self.stats.packets_sent += 1
        self.stats.bytes_tx += len(packet)
        # when the line is free again: packets sent back to back queue behind each other
        self._wire_free_at = (max(time.monotonic(), self._wire_free_at)
                              + len(packet) * self._port.tx_ms_per_byte / 1000.0)
        return True

    def _receive(self, expected: list[tuple[int, int]], tx_bytes: int, sent_at: float,
                 due: float | None = None) -> dict[int, p.Status]:
        """Collect stuffed status packets, one per expected ID, each with its own wait.

        The first reply gets the full timeout (our packet's wire time included); each
        reply that arrives restarts the wait for the next, so one silent servo costs
        one reply wait and the others are still collected.
        """
        pending = dict(expected)
        largest = p.STATUS_OVERHEAD + max(size for _, size in expected)
        first_ms = self.reply_timeout_ms(tx_bytes, largest)
        gap_s = self.reply_timeout_ms(0, largest) / 1000.0
        self.last_timeout_ms = first_ms
        deadline = sent_at + first_ms / 1000.0
        stream = p.StatusStream()
        got: dict[int, p.Status] = {}
        while pending:
            data = self._port.read_until(deadline, sum(p.STATUS_OVERHEAD + n for n in pending.values())
                                         - stream.pending_bytes, due)
            if not data:
                break
            self.stats.bytes_rx += len(data)
            for status in stream.feed(data):
                size = pending.get(status.dxl_id)
                if size is None or (len(status.params) != size and not status.refused):
                    # a late reply of an earlier transaction, or not ours: never take it as the answer
                    self.stats.discarded_bytes += p.STATUS_OVERHEAD + len(status.params)
                    continue
                del pending[status.dxl_id]
                got[status.dxl_id] = status
                self._note_status(status)
                deadline = max(deadline, time.monotonic() + gap_s)
        if pending:
            self.stats.timeouts += 1
        self.stats.crc_errors += stream.crc_errors
        self.stats.discarded_bytes += stream.discarded_bytes
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
            data = self._port.read_until(deadline, total - reply.received_bytes, due)
            if not data:
                break
            self.stats.bytes_rx += len(data)
            reply.feed(data)
            deadline = max(deadline, time.monotonic() + gap_s)
        got = reply.segments()
        for status in got.values():
            self._note_status(status)
        if not reply.complete:
            self.stats.timeouts += 1
        self.stats.crc_errors += reply.crc_errors
        self.stats.discarded_bytes += reply.discarded_bytes
        return got

    def _note_status(self, status: p.Status) -> None:
        self.last_error_bytes[status.dxl_id] = status.error
        if status.refused:
            self.stats.servo_errors += 1
            if self.verbose:
                self._log("warning", f"ID {status.dxl_id} refused: {p.error_text(status.error)}")

    def _pause_before_retry(self) -> None:
        self.stats.retries += 1
        if self.retry_interval_ms:
            time.sleep(self.retry_interval_ms / 1000.0)

    def _lose(self, exc: BaseException) -> None:
        """The device went away mid-run: fail fast from now on until reopen()."""
        if not self._port.lost:
            self._port.lost = True
            self.stats.disconnects += 1
            self._log("error", f"{self.device} stopped working ({exc}): the port hung up (adapter unplugged, or "
                               "another process reading it?); transactions fail until reopen() succeeds")
        self._port.close()

    def _why(self, status: p.Status | None) -> str:
        if self._port.lost:
            return "device lost"
        if not self._port.is_open:
            return "port closed"
        if status is None:
            return f"no reply within {self.last_timeout_ms:.1f} ms"
        return p.error_text(status.error)

    def _log(self, level: str, message: str) -> None:
        method = getattr(self._logger, level, None) or getattr(self._logger, "info")
        method(message)

    @contextmanager
    def _transaction(self) -> Iterator["Outcome"]:
        with self._lock:
            self._settle()
            start = time.monotonic()
            outcome = Outcome(self)
            try:
                yield outcome
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - start


def _reply_bytes(expected: list[tuple[int, int]], fast: bool) -> int:
    """Bytes on the wire of the replies to a read of ``expected`` ``(id, size)``: one status packet
    each, or one fast-read packet (header, ID, length, instruction, then ERR ID data CRC each)."""
    if fast:
        return 8 + sum(size + 4 for _, size in expected)
    return sum(p.STATUS_OVERHEAD + size for _, size in expected)


def _check_id(dxl_id: int) -> int:
    """The ID as a plain int (numpy integers welcome); ValueError outside 0..252."""
    try:
        value = operator.index(dxl_id)
    except TypeError:
        value = -1
    if not 0 <= value <= p.MAX_ID:
        raise ValueError(f"invalid Dynamixel ID {dxl_id!r}: servo IDs are 0..252")
    return value


def _unique_ids(ids: Iterable[int]) -> list[int]:
    order: list[int] = []
    for dxl_id in ids:
        value = _check_id(dxl_id)
        if value not in order:
            order.append(value)
    return order
