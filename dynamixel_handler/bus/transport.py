"""The wire under ``DynamixelBus``: one transaction at a time, retries, reply gathering, the
read left in flight, counters. Everything above it (reads, writes, single-servo instructions)
goes through ``Transport._transaction`` or ``Transport._start_group_read``, so a read in flight is
always gathered before anything else is sent and no reply is taken for another transaction's.
"""
from __future__ import annotations

import logging
import threading
import time
from contextlib import contextmanager
from typing import Iterator

import serial

from ..protocol import host as p
from .errors import BusError
from .group_read import GroupRead
from .port import SerialPort
from .receive import Receiving
from .stats import BusStats, Outcome

#: cap of the learnt reply lag [s]
_MAX_REPLY_LAG_S = 0.02


class Transport(Receiving):
    """One Protocol 2.0 serial line: the port, one transaction at a time, retries and counters.

    Reads return ``None``/missing keys and writes return ``False`` on failure; they
    never raise for communication problems (a vanished device included), only
    :class:`BusError` from :meth:`open`/:meth:`reopen`/:meth:`set_baudrate` and
    ``ValueError`` for invalid arguments. A failed transaction is retried up to
    ``retry_num`` times, ``retry_interval_ms`` apart.
    """

    def __init__(self, device: str, baudrate: int = 57600, latency_timer_ms: float = 16.0,
                 retry_num: int = 5, retry_interval_ms: float = 4.0, verbose: bool = False,
                 logger: object = None, timeout_margin_ms: float = 2.0, direct_io: bool = True) -> None:
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
        # direct_io=False: the port's bytes through pyserial's read/write (same results, slower)
        self._port = SerialPort(device, baudrate, latency_timer_ms, log=self._log, direct_io=direct_io)
        self._lock = threading.RLock()
        self._ever_opened = False
        self._inflight: GroupRead | None = None  # a sync read sent but not yet gathered
        self._wire_free_at = 0.0
        #: how much later than their wire time replies arrive (learnt, seconds)
        self.reply_lag_s = 0.0
        # sync read packets and their (id, size) list by (address, length, ids as given, fast)
        self._packets: dict[tuple[int, int, tuple[int, ...], bool], tuple[bytes, tuple[tuple[int, int], ...]]] = {}

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

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _finish_group_read(self, read: GroupRead) -> None:
        """Gather the replies of ``read`` (retrying the instruction when nobody answered)."""
        with self._lock:
            if read.done:
                return
            if self._inflight is read:
                self._inflight = None
            data: dict[int, bytes] = {}
            try:
                data = self._group_replies(read)
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

    def _group_replies(self, read: GroupRead) -> dict[int, bytes]:
        """The data of the servos that answered ``read``; the instruction is sent again (up to
        ``retry_num`` times) while nobody answers and the port is usable."""
        waited = read.sent and self._port.waiting() < read.reply_bytes
        replies = self._gather(read.expected, len(read.packet), read.fast, read.started) if read.sent else None
        if replies is not None and len(replies) == len(read.expected):
            self._learn_lag(read, waited)
        for _ in range(self.retry_num):
            if replies is None or replies:
                break
            self._pause_before_retry()
            replies = self._exchange(read.packet, read.expected, read.fast)
        return {i: s.params for i, s in (replies or {}).items() if not s.refused}

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

    def _send_or_lose(self, packet: bytes, flush: bool = True) -> bool:
        """Send ``packet``; False if the port is unusable. ``flush``: drop what waits in the input
        first (stale replies), which a packet without a reply can leave to the next one that has."""
        if not self._ever_opened:
            raise BusError(f"{self.device} is not open: call open() first.")
        if not self._port.is_open:
            return False
        try:
            if flush:
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

    def _pause_before_retry(self) -> None:
        self.stats.retries += 1
        if self.retry_interval_ms:
            time.sleep(self.retry_interval_ms / 1000.0)

    def _why(self, status: p.Status | None) -> str:
        if self._port.lost:
            return "device lost"
        if not self._port.is_open:
            return "port closed"
        if status is None:
            return f"no reply within {self.last_timeout_ms:.1f} ms"
        return p.error_text(status.error)

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


