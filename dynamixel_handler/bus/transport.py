"""The wire under ``DynamixelBus``: one transaction at a time, retries, the read left in flight,
counters. ``Reads``, ``Writes`` and ``Instructions`` all go through one ``Transport``
(:meth:`Transport.transaction` or :meth:`Transport.start_group_read`), so a read in flight is
always gathered before anything else is sent and no reply is taken for another transaction's.
"""
from __future__ import annotations

import logging
import threading
import time
from contextlib import contextmanager
from typing import Any, Iterator, TypeVar

import serial

from ..protocol.framers import Framer
from .errors import BusError
from .group_read import GroupRead, reply_bytes
from .line import Line
from .port import SerialPort
from .receive import Receiver
from .result import Failure, Result
from .stats import BusStats

T = TypeVar("T")

#: cap of the learnt reply lag [s]
_MAX_REPLY_LAG_S = 0.02


class Outcome:
    """One transaction's result: booked into the counters, and why it failed."""

    __slots__ = ("_transport",)

    def __init__(self, transport: Transport) -> None:
        self._transport = transport

    def ok(self, answered: int, addressed: int) -> None:
        stats = self._transport.stats
        stats.successes += 1
        if answered >= addressed:
            stats.full_successes += 1

    def fail(self, reason: str) -> str:
        """Note a failure (a log line when verbose); returns ``reason`` for the call's result."""
        transport = self._transport
        if transport.rx.verbose:
            transport.log("warning", reason)
        return reason

    def failed(self, value: T, what: str, status: Any = None, *, framer: Framer | None = None) -> Result[T]:
        """The result of a transaction that got ``status`` (None: no reply) instead of an answer:
        ``value`` (the failure value), the kind and ``what`` with the reason. ``framer``: the
        protocol of ``status``, needed when there is one."""
        kind, reason = self._transport.why(status, framer=framer)
        return Result(value, kind, self.fail(f"{what}: {reason}"), None if status is None else status.error)


def _taken(read: GroupRead, replies: dict[int, Any]) -> dict[int, bytes]:
    """The data of the replies that are answers (not refusals); Protocol 1.0: their error bytes
    kept on the read (the servo's state is in each status's error byte)."""
    answered = {i: s for i, s in replies.items() if not s.refused}
    if read.framer.state_in_error_byte:
        read.errors = {i: s.error for i, s in answered.items()}
    return {i: s.params for i, s in answered.items()}


class Transport:
    """One Protocol 2.0 serial line: the port, one transaction at a time, retries and counters.

    Nothing here raises for communication problems (a vanished device included), only
    :class:`BusError` from :meth:`open`/:meth:`reopen`/:meth:`set_baudrate` and from sending on a
    port never opened. A failed transaction is retried up to ``retry_num`` times,
    ``retry_interval_ms`` apart.
    """

    def __init__(self, device: str, baudrate: int = 57600, latency_timer_ms: float = 16.0,
                 retry_num: int = 5, retry_interval_ms: float = 4.0, verbose: bool = False,
                 logger: object = None, timeout_margin_ms: float = 2.0, direct_io: bool = True,
                 line: Line | None = None) -> None:
        if latency_timer_ms <= 0:
            raise ValueError(f"latency_timer_ms must be > 0, got {latency_timer_ms}")
        self.retry_num = max(0, int(retry_num))
        self.retry_interval_ms = max(0.0, float(retry_interval_ms))
        self.stats = BusStats()
        self._logger = logger if logger is not None else logging.getLogger("dynamixel_handler.bus")
        # direct_io=False: the port's bytes through pyserial's read/write (same results, slower)
        #: the line under the bus (the serial port unless another backend is given)
        self.port: Line = line if line is not None else SerialPort(device, baudrate, latency_timer_ms, log=self.log,
                                                                   direct_io=direct_io)
        self.rx = Receiver(self.port, self.stats, self.log, max(0.0, float(timeout_margin_ms)), verbose)
        self.lock = threading.RLock()
        self._ever_opened = False
        self._inflight: GroupRead | None = None  # a sync read sent but not yet gathered
        #: a servo whose reply did not come in time: ``(ID, time.monotonic() until which it may still
        #: come, the packet)``. A status names no address, so a late reply to a read of one item would
        #: be taken for the next read of another of the same size from that servo (``_exchange``
        #: waits it out before another packet to it; the same packet again may take it as its answer)
        self._late: tuple[int, float, bytes] | None = None

    def log(self, level: str, message: str) -> None:
        method = getattr(self._logger, level, None) or getattr(self._logger, "info")
        method(message)

    # ------------------------------------------------------------ the port
    def open(self) -> None:
        """Open the device; BusError (what, why, what to do) if it is missing, busy, not a tty."""
        with self.lock:
            self.port.open()
            self._ever_opened = True

    def close(self) -> None:
        with self.lock:
            self.port.close()

    def reopen(self) -> None:
        """Close and open again, e.g. after the adapter was unplugged and plugged back."""
        with self.lock:
            self.port.close()
            self.port.lost = False
            self.port.open()
            self._ever_opened = True

    def set_baudrate(self, baudrate: int) -> None:
        with self.lock:
            self.port.set_baudrate(baudrate)

    # ------------------------------------------------------------ transactions
    @contextmanager
    def transaction(self) -> Iterator[Outcome]:
        """One transaction: the read in flight is gathered first, the time and count booked after."""
        with self.lock:
            self._settle()
            start = time.monotonic()
            try:
                yield Outcome(self)
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - start

    def unicast(self, dxl_id: int, instruction: int, params: bytes, reply_params: int,
                retries: int | None = None, *, framer: Framer) -> Any:
        """Send to one servo in ``framer``'s protocol and return its status (None: no reply);
        retried on silence, noise and a packet the servo got corrupted."""
        packet = framer.instruction(dxl_id, instruction, params)
        attempts = 1 + (self.retry_num if retries is None else max(0, retries))
        status = None
        missed = False  # a reply that did not come in time may still come: waited out before another packet
        for attempt in range(attempts):
            if attempt:
                self.pause_before_retry()
            replies = self._exchange(packet, [(dxl_id, reply_params)], False, framer=framer)
            if replies is None:
                return None
            status = replies.get(dxl_id)
            missed = missed or (status is None and dxl_id != framer.broadcast_id)
            if missed:
                self._late = (dxl_id, time.monotonic() + self.rx.last_timeout_ms / 1000.0, packet)
            if status is not None and not framer.corrupted(status.error):
                return status
        return status

    def send(self, packet: bytes, flush: bool = True) -> bool:
        """Send ``packet``; False if the port is unusable. ``flush``: drop what waits in the input
        first (stale replies), which a packet without a reply can leave to the next one that has."""
        if not self._ever_opened:
            raise BusError(f"{self.port.device} is not open: call open() first.")
        port = self.port
        if not port.is_open:
            return False
        try:
            if flush:
                self.stats.discarded_bytes += port.discard_input()
            port.write(packet)
        except (OSError, serial.SerialException) as exc:
            self.rx.lose(exc)
            return False
        self.stats.packets_sent += 1
        self.stats.bytes_tx += len(packet)
        # when the line is free again: packets sent back to back queue behind each other
        rx = self.rx
        rx.wire_free_at = max(time.monotonic(), rx.wire_free_at) + len(packet) * port.tx_ms_per_byte / 1000.0
        return True

    def broadcast(self, packet: bytes) -> bool:
        """Send a packet that has no reply: the input is flushed before the next packet that has one."""
        return self.send(packet, flush=False)

    def pause_before_retry(self) -> None:
        self.stats.retries += 1
        if self.retry_interval_ms:
            time.sleep(self.retry_interval_ms / 1000.0)

    def why(self, status: Any, *, framer: Framer | None = None) -> tuple[Failure, str]:
        """Why a transaction got ``status`` (None: no reply) instead of an answer: the kind, in words."""
        if self.port.lost:
            return Failure.DEVICE_LOST, "device lost"
        if not self.port.is_open:
            return Failure.PORT_CLOSED, "port closed"
        if status is None:
            return Failure.NO_REPLY, f"no reply within {self.rx.last_timeout_ms:.1f} ms"
        assert framer is not None, "a status is read in the framing of its protocol"
        return Failure.REFUSED, framer.error_text(status.error)

    def _nobody(self) -> tuple[Failure, str]:
        """Why a group read got no reply: the port, or no servo answered."""
        return self.why(None) if not self.port.is_open else (Failure.NOBODY_ANSWERED, "no servo answered")

    def _exchange(self, packet: bytes, expected: list[tuple[int, int]], fast: bool,
                  *, framer: Framer) -> dict[int, Any] | None:
        """Send ``packet`` and gather the expected replies; None if the port is unusable."""
        self._wait_out_late(expected, packet)
        if not self.send(packet):
            return None
        return self.rx.gather(expected, len(packet), fast, framer=framer)

    def _wait_out_late(self, expected: list[tuple[int, int]], packet: bytes) -> None:
        """Before another packet to a servo whose last reply did not come in time, wait until it
        would have come (one timeout more) so that ``send`` drops it, rather than take it for this
        packet's answer. The same packet again (a retry) takes it as its own answer: no wait."""
        late = self._late
        if late is None:
            return
        left = late[1] - time.monotonic()
        if left <= 0:
            self._late = None
        elif packet != late[2] and any(dxl_id == late[0] for dxl_id, _ in expected):
            self._late = None
            time.sleep(left)

    # ------------------------------------------------------------ the group read on the wire
    def start_group_read(self, packet: bytes, expected: list[tuple[int, int]], fast: bool,
                         what: str, *, framer: Framer) -> GroupRead:
        """Send a group read and leave it on the wire; its ``result()`` gathers the replies (one
        status per servo in ``framer``'s protocol, or one fast-read reply)."""
        with self.lock:
            self._settle()
            read = GroupRead(self._finish_group_read, packet, expected, fast, what)
            read.framer = framer
            read.sent = self.send(packet)
            if read.sent:
                rx = self.rx
                read.reply_bytes = reply_bytes(expected, fast, framer.status_overhead)
                read.eta = min(rx.wire_free_at + read.reply_bytes * self.port.tx_ms_per_byte / 1000.0
                               + rx.reply_lag_s,
                               read.started + rx.reply_timeout_ms(len(packet), read.reply_bytes) / 1000.0)
                self._inflight = read
            return read

    @property
    def inflight_eta(self) -> float | None:
        """``time.monotonic()`` by which the replies of the read in flight should be in, or None."""
        read = self._inflight
        return read.eta if read is not None else None

    def _settle(self) -> None:
        """End a read left in flight before anything else goes on the wire."""
        if self._inflight is not None:
            self._finish_group_read(self._inflight)

    def _finish_group_read(self, read: GroupRead) -> None:
        """Gather the replies of ``read`` (retrying the instruction when nobody answered)."""
        with self.lock:
            if read.done:
                return
            if self._inflight is read:
                self._inflight = None
            data: dict[int, bytes] = {}
            failure: Failure | None = None
            why = ""
            try:
                data = self._group_replies(read)
                if data:
                    Outcome(self).ok(len(data), len(read.expected))
                else:
                    failure, why = self._nobody()
                    why = Outcome(self).fail(f"{read.what}: {why}")
                missing = [i for i, _ in read.expected if i not in data]
                if missing and data and self.rx.verbose:
                    self.log("warning", f"{read.what}: no valid reply from ID {missing}")
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - read.started
                read.finish({i: data[i] for i, _ in read.expected if i in data}, failure, why)

    def _group_replies(self, read: GroupRead) -> dict[int, bytes]:
        """The data of the servos that answered ``read``; the instruction is sent again (up to
        ``retry_num`` times) while nobody answers and the port is usable."""
        waited = read.sent and self.port.waiting() < read.reply_bytes
        framer = read.framer
        replies = (self.rx.gather(read.expected, len(read.packet), read.fast, read.started, framer=framer)
                   if read.sent else None)
        if replies is not None and len(replies) == len(read.expected):
            self._learn_lag(read, waited)
        for _ in range(self.retry_num):
            if replies is None or replies:
                break
            self.pause_before_retry()
            replies = self._exchange(read.packet, read.expected, read.fast, framer=framer)
        return _taken(read, replies or {})

    def _learn_lag(self, read: GroupRead, waited: bool) -> None:
        """Track how much later than their wire time replies arrive (adapter latency, the servos'
        return delay, scheduling), so ``eta`` of the next read is right: from reads that were
        waited for; a reply that was already complete when asked for pulls the estimate down."""
        rx = self.rx
        if waited:
            late = max(0.0, time.monotonic() - (read.eta - rx.reply_lag_s))
            rx.reply_lag_s += 0.2 * (min(late, _MAX_REPLY_LAG_S) - rx.reply_lag_s)
        else:
            rx.reply_lag_s *= 0.8
