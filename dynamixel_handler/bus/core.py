"""DynamixelBus: every Protocol 2.0 transaction the handler needs, with retries and counters.

This is the one place that talks to the servos. It sends packets built by
:mod:`.protocol` through :class:`.port.SerialPort` (which uses ``dynamixel_sdk``'s
PortHandler for the serial handle) and never lets the known defects of
``dynamixel_sdk`` 4.1.0's packet handler reach users:

1. Unstuffed instruction packets: ``addStuffing`` rebinds its local list when a
   ``FF FF FD`` needs stuffing, so the caller's packet goes out unstuffed with the
   unstuffed length. We stuff in :func:`.protocol.build_instruction`.
2. ``fastBulkReadRx`` finds each servo's length with ``param.index(id)``, which hits
   address/length bytes equal to the ID. We parse the fast reply by position in
   :class:`.protocol.FastReply`, checking the ID at each position.
3. ``action()`` never reads the unicast status reply, which then arrives during the
   next transaction (after its input flush) and is taken as that transaction's
   answer. We wait for and consume that reply, flush before every packet, and only
   accept a reply with the expected ID and parameter length.
4. ``GroupSyncRead`` stops at the first silent servo and reports failure for all.
   We keep every reply that arrived, with a per-reply wait.
5. ``rxPacket`` spins on a non-blocking read. We block in ``select()``.
6. ``PortHandler`` hard-codes a 16 ms latency timer in its timeouts. Ours use the
   configured latency: ``2 * latency + bytes * byte_time + margin``.

Only ``DynamixelBus`` methods are meant for callers; it is ROS-free.
"""
from __future__ import annotations

import dataclasses
import logging
import operator
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping

import serial

from ..protocol import host as p
from .errors import BusError
from .port import SerialPort

#: Scans of more IDs than this use one broadcast ping instead of a ping per ID.
BROADCAST_SCAN_MIN_IDS = 5
#: Time slot each ID gets in a broadcast ping reply train, on top of its packet's wire time.
BROADCAST_PING_SLOT_MS = 3.0
_PING_REPLY_PARAMS = 3
#: sync read packets kept built (the loop asks for the same few reads over and over)
_PACKET_CACHE_SIZE = 64
#: cap of the learnt reply lag [s]
_MAX_REPLY_LAG_S = 0.02


@dataclass
class BusStats:
    """Counters since open (or the last ``reset``); cheap to copy for a per-period log line.

    ``transactions`` counts calls that used the wire (a sync read of 10 servos is one),
    ``packets_sent`` every instruction packet including retries.
    """

    transactions: int = 0
    successes: int = 0          # at least one addressed servo answered (or a no-reply write was sent)
    full_successes: int = 0     # every addressed servo answered
    packets_sent: int = 0
    retries: int = 0
    timeouts: int = 0           # waits that ended with an expected reply missing
    crc_errors: int = 0
    servo_errors: int = 0       # status packets whose error number says the servo refused
    discarded_bytes: int = 0    # stale replies and noise dropped from the input
    bytes_tx: int = 0
    bytes_rx: int = 0
    time_s: float = 0.0         # wall time spent inside bus calls
    disconnects: int = 0

    @property
    def success_rate(self) -> float:
        return self.successes / self.transactions if self.transactions else 1.0

    @property
    def full_success_rate(self) -> float:
        return self.full_successes / self.transactions if self.transactions else 1.0

    def copy(self) -> "BusStats":
        return dataclasses.replace(self)

    def delta(self, earlier: "BusStats") -> "BusStats":
        """Counters accumulated since the snapshot ``earlier`` (for a per-period log line)."""
        return BusStats(**{f.name: getattr(self, f.name) - getattr(earlier, f.name)
                           for f in dataclasses.fields(self)})

    def reset(self) -> None:
        for item in dataclasses.fields(self):
            setattr(self, item.name, item.default)


class DynamixelBus:
    """One Protocol 2.0 serial bus.

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

    # ------------------------------------------------------------------ lifecycle
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

    def __enter__(self) -> "DynamixelBus":
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

    # ------------------------------------------------------------------ single servo
    def ping(self, dxl_id: int, retries: int | None = None) -> int | None:
        """Model number of ``dxl_id``, or None if it does not answer."""
        dxl_id = _check_id(dxl_id)
        with self._transaction() as tx:
            status = self._unicast(dxl_id, p.PING, b"", _PING_REPLY_PARAMS, retries)
            if status is None or status.refused:
                tx.fail(f"ping ID {dxl_id}: {self._why(status)}")
                return None
            tx.ok(1, 1)
            self.firmware_versions[dxl_id] = status.params[2]
            return status.params[0] | (status.params[1] << 8)

    def read(self, dxl_id: int, address: int, size: int) -> bytes | None:
        """``size`` raw bytes from the control table of ``dxl_id``, or None."""
        dxl_id = _check_id(dxl_id)
        with self._transaction() as tx:
            status = self._unicast(dxl_id, p.READ, p.u16(address) + p.u16(size), size)
            if status is None or status.refused:
                tx.fail(f"read ID {dxl_id} @{address}x{size}: {self._why(status)}")
                return None
            tx.ok(1, 1)
            return status.params

    def write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Write raw bytes; True when the servo acknowledged (broadcast: when sent)."""
        return self._write_like(p.WRITE, "write", dxl_id, p.u16(address) + bytes(data))

    def reg_write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Register a write to be executed by :meth:`action`."""
        return self._write_like(p.REG_WRITE, "reg_write", dxl_id, p.u16(address) + bytes(data))

    def action(self, dxl_id: int = p.BROADCAST_ID) -> bool:
        """Execute registered writes. A unicast action's status reply is read and consumed here."""
        return self._write_like(p.ACTION, "action", dxl_id, b"")

    def reboot(self, dxl_id: int) -> bool:
        """Reboot a servo (it needs a few hundred ms before it answers again)."""
        return self._write_like(p.REBOOT, "reboot", dxl_id, b"")

    def clear_multi_turn(self, dxl_id: int) -> bool:
        """Reset the present position to within one turn (Clear instruction, servo must be stopped)."""
        return self._write_like(p.CLEAR, "clear multi-turn", dxl_id, b"\x01\x44\x58\x4c\x22")

    def factory_reset(self, dxl_id: int, option: int = 0x02) -> bool:
        """Factory reset; option 0xFF all, 0x01 all but ID, 0x02 (default) all but ID and baud rate."""
        if option not in (0x01, 0x02, 0xFF):
            raise ValueError(f"factory reset option must be 0x01, 0x02 or 0xFF, got {option:#x}")
        return self._write_like(p.FACTORY_RESET, "factory reset", dxl_id, bytes([option]))

    def _write_like(self, instruction: int, what: str, dxl_id: int, params: bytes) -> bool:
        if dxl_id != p.BROADCAST_ID:
            dxl_id = _check_id(dxl_id)
        with self._transaction() as tx:
            if dxl_id == p.BROADCAST_ID:
                sent = self._broadcast(p.build_instruction(dxl_id, instruction, params))
                if sent:
                    tx.ok(1, 1)
                else:
                    tx.fail(f"{what} broadcast: {self._why(None)}")
                return sent
            status = self._unicast(dxl_id, instruction, params, 0)
            if status is None or status.refused:
                tx.fail(f"{what} ID {dxl_id}: {self._why(status)}")
                return False
            tx.ok(1, 1)
            return True

    # ------------------------------------------------------------------ groups
    def sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> dict[int, bytes]:
        """Same item from many servos in one instruction; returns the IDs that answered.

        A silent servo costs one reply wait and never empties the others' data. The
        instruction is retried only when nobody answered. ``fast`` uses Fast Sync Read
        (X firmware 45+, P 12+): one unstuffed reply for all servos.
        """
        return self.start_sync_read(address, length, ids, fast).result()

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> "GroupRead":
        """Send a sync read and return at once; ``result()`` of the returned read waits for the
        replies (same result as :meth:`sync_read`). Meanwhile the caller may do work that needs no
        bus; any other transaction first waits for this read to end, so none is ever lost.
        """
        order = tuple(_unique_ids(ids))
        if not order:
            return GroupRead.finished({})
        key = (address, length, order, fast)
        packet = self._packets.get(key)
        if packet is None:
            instruction = p.FAST_SYNC_READ if fast else p.SYNC_READ
            packet = p.build_instruction(p.BROADCAST_ID, instruction, p.sync_read_params(address, length, order))
            if len(self._packets) >= _PACKET_CACHE_SIZE:
                self._packets.clear()
            self._packets[key] = packet
        return self._start_group_read(packet, [(i, length) for i in order], fast,
                                      f"{'fast ' if fast else ''}sync read @{address}x{length}")

    def bulk_read(self, requests: Mapping[int, tuple[int, int]], fast: bool = False) -> dict[int, bytes]:
        """Different ``(address, size)`` per servo in one instruction; returns the IDs that answered."""
        requests = {_check_id(i): (int(a), int(n)) for i, (a, n) in requests.items()}
        order = list(requests)
        if not order:
            return {}
        instruction = p.FAST_BULK_READ if fast else p.BULK_READ
        params = p.bulk_read_params((i, requests[i][0], requests[i][1]) for i in order)
        packet = p.build_instruction(p.BROADCAST_ID, instruction, params)
        return self._group_read(packet, [(i, requests[i][1]) for i in order], fast,
                                f"{'fast ' if fast else ''}bulk read")

    def sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> bool:
        """Same item to many servos in one broadcast packet (no reply); True when sent."""
        return self.send_prepared(self.prepare_sync_write(address, length, data))

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> "PreparedWrite":
        """Check and build a sync write now, to send it later with :meth:`send_prepared` (e.g.
        while a read is on the wire, so that the packet is ready the moment the line is free).
        ValueError for invalid IDs or data lengths, as :meth:`sync_write`."""
        data = {_check_id(i): bytes(chunk) for i, chunk in data.items()}
        if not data:
            return PreparedWrite(address, length, (), b"")
        params = p.sync_write_params(address, length, data.items())
        return PreparedWrite(address, length, tuple(data),
                             p.build_instruction(p.BROADCAST_ID, p.SYNC_WRITE, params))

    def send_prepared(self, prepared: "PreparedWrite") -> bool:
        """Send a write built by :meth:`prepare_sync_write`; True when sent (or nothing to send)."""
        if not prepared.packet:
            return True
        return self._broadcast_txn(prepared.packet, f"sync write @{prepared.address}x{prepared.length}")

    def bulk_write(self, data: Mapping[int, tuple[int, bytes]]) -> bool:
        """Different ``(address, bytes)`` per servo in one broadcast packet (no reply); True when sent."""
        data = {_check_id(i): (int(a), bytes(chunk)) for i, (a, chunk) in data.items()}
        order = list(data)
        if not order:
            return True
        params = p.bulk_write_params((i, data[i][0], bytes(data[i][1])) for i in order)
        return self._broadcast_txn(p.build_instruction(p.BROADCAST_ID, p.BULK_WRITE, params),
                                   "bulk write")

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        """``{id: model_number}`` of the servos among ``ids`` that answer a ping.

        Wide ranges use one broadcast ping (replies come in ID order, so its wait grows
        with the highest ID); if that reply train was garbled (collisions, CRC errors)
        the IDs not found are pinged one by one. Unicast scan pings are not retried.
        """
        wanted = sorted(_unique_ids(ids))
        if not wanted:
            return {}
        if broadcast is None:
            broadcast = len(wanted) >= BROADCAST_SCAN_MIN_IDS
        found: dict[int, int] = {}
        garbled = True
        if broadcast:
            found, garbled = self._broadcast_ping(wanted)
        if garbled:
            for dxl_id in wanted:
                if dxl_id not in found:
                    model = self.ping(dxl_id, retries=0)
                    if model is not None:
                        found[dxl_id] = model
        return dict(sorted(found.items()))

    # ------------------------------------------------------------------ internals
    def _group_read(self, packet: bytes, expected: list[tuple[int, int]], fast: bool,
                    what: str) -> dict[int, bytes]:
        return self._start_group_read(packet, expected, fast, what).result()

    def _start_group_read(self, packet: bytes, expected: list[tuple[int, int]], fast: bool,
                          what: str) -> "GroupRead":
        with self._lock:
            self._settle()
            read = GroupRead(self, packet, expected, fast, what)
            read.sent = self._send_or_lose(packet)
            if read.sent:
                read.reply_bytes = _reply_bytes(expected, fast)
                read.eta = min(self._wire_free_at + read.reply_bytes * self._port.tx_ms_per_byte / 1000.0
                               + self.reply_lag_s,
                               read.started + self.reply_timeout_ms(len(packet), read.reply_bytes) / 1000.0)
                self._inflight = read
            return read

    def _finish_group_read(self, read: "GroupRead") -> None:
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
                    _Outcome(self).ok(len(data), len(read.expected))
                else:
                    _Outcome(self).fail(f"{read.what}: no servo answered")
                missing = [i for i, _ in read.expected if i not in data]
                if missing and data and self.verbose:
                    self._log("warning", f"{read.what}: no valid reply from ID {missing}")
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - read.started
                read.finish({i: data[i] for i, _ in read.expected if i in data})

    def _learn_lag(self, read: "GroupRead", waited: bool) -> None:
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

    def _broadcast_txn(self, packet: bytes, what: str) -> bool:
        with self._transaction() as tx:
            sent = self._broadcast(packet)
            if sent:
                tx.ok(1, 1)
            else:
                tx.fail(f"{what}: {self._why(None)}")
            return sent

    def _broadcast(self, packet: bytes) -> bool:
        return self._exchange(packet, [], False) is not None

    def _broadcast_ping(self, wanted: list[int]) -> tuple[dict[int, int], bool]:
        packet = p.build_instruction(p.BROADCAST_ID, p.PING)
        reply_bytes = p.STATUS_OVERHEAD + _PING_REPLY_PARAMS
        slots = (max(wanted) + 1) * (reply_bytes * self._port.tx_ms_per_byte + BROADCAST_PING_SLOT_MS)
        wait_ms = self.reply_timeout_ms(len(packet), 0) + slots
        found: dict[int, int] = {}
        with self._transaction() as tx:
            stream = p.StatusStream()
            if not self._send_or_lose(packet):
                tx.fail(f"broadcast ping: {self._why(None)}")
                return {}, False
            self.last_timeout_ms = wait_ms
            deadline = time.monotonic() + wait_ms / 1000.0
            try:
                while len(found) < len(wanted):
                    data = self._port.read_until(deadline)
                    if not data:
                        break
                    self.stats.bytes_rx += len(data)
                    for status in stream.feed(data):
                        if len(status.params) == _PING_REPLY_PARAMS and status.dxl_id in wanted:
                            self._note_status(status)
                            self.firmware_versions[status.dxl_id] = status.params[2]
                            found[status.dxl_id] = status.params[0] | (status.params[1] << 8)
            except (OSError, serial.SerialException) as exc:
                self._lose(exc)
            garbled = bool(stream.crc_errors or stream.discarded_bytes or stream.pending_bytes)
            self.stats.crc_errors += stream.crc_errors
            self.stats.discarded_bytes += stream.discarded_bytes + stream.pending_bytes
            if found:
                tx.ok(1, 1)
            else:
                tx.fail("broadcast ping: no servo answered")
            return found, garbled

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
    def _transaction(self) -> Iterator["_Outcome"]:
        with self._lock:
            self._settle()
            start = time.monotonic()
            outcome = _Outcome(self)
            try:
                yield outcome
            finally:
                self.stats.transactions += 1
                self.stats.time_s += time.monotonic() - start


@dataclass(frozen=True)
class PreparedWrite:
    """A sync write checked and built ahead of sending (:meth:`DynamixelBus.prepare_sync_write`).
    ``dummies``: data for in-process dummy servos (``BusWithDummies``), written when it is sent."""

    address: int
    length: int
    ids: tuple[int, ...]
    packet: bytes
    dummies: Mapping[int, bytes] = dataclasses.field(default_factory=dict)


class GroupRead:
    """A sync read on the wire: ``result()`` waits for its replies (once; later calls return the
    same dict). ``eta`` is when they should be in (``time.monotonic()``)."""

    def __init__(self, bus: DynamixelBus | None, packet: bytes, expected: list[tuple[int, int]], fast: bool,
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
    def finished(cls, data: dict[int, bytes]) -> "GroupRead":
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


class _Outcome:
    """Books one transaction's result into the stats."""

    def __init__(self, bus: DynamixelBus) -> None:
        self._bus = bus

    def ok(self, answered: int, addressed: int) -> None:
        self._bus.stats.successes += 1
        if answered >= addressed:
            self._bus.stats.full_successes += 1

    def fail(self, reason: str) -> None:
        self._bus.last_failure = reason
        if self._bus.verbose:
            self._bus._log("warning", reason)


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
