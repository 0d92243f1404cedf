"""DynamixelBus: every Protocol 2.0 transaction the handler needs, with retries and counters.

This is the one place that talks to the servos. It sends packets built by
:mod:`..protocol.host` through :class:`.port.SerialPort` (which uses ``dynamixel_sdk``'s
PortHandler for the serial handle) and never lets the known defects of
``dynamixel_sdk`` 4.1.0's packet handler reach users:

1. Unstuffed instruction packets: ``addStuffing`` rebinds its local list when a
   ``FF FF FD`` needs stuffing, so the caller's packet goes out unstuffed with the
   unstuffed length. We stuff in :func:`..protocol.host.build_instruction`.
2. ``fastBulkReadRx`` finds each servo's length with ``param.index(id)``, which hits
   address/length bytes equal to the ID. We parse the fast reply by position in
   :class:`..protocol.host.FastReply`, checking the ID at each position.
3. ``action()`` never reads the unicast status reply, which then arrives during the
   next transaction (after its input flush) and is taken as that transaction's
   answer. We wait for and consume that reply, flush before every packet, and only
   accept a reply with the expected ID and parameter length.
4. ``GroupSyncRead`` stops at the first silent servo and reports failure for all.
   We keep every reply that arrived, with a per-reply wait.
5. ``rxPacket`` spins on a non-blocking read. We block in ``select()``.
6. ``PortHandler`` hard-codes a 16 ms latency timer in its timeouts. Ours use the
   configured latency: ``2 * latency + bytes * byte_time + margin``.

``DynamixelBus`` is a front over its parts, each an object: ``transport.Transport`` (the line, one
transaction at a time, retries, the read in flight, counters) with its ``receive.Receiver`` (reply
gathering and timing), and over that transport ``reads.Reads`` (pings, group reads, scan),
``writes.Writes`` (group writes) and ``instructions.Instructions`` (single-servo instructions).
Each call comes in two forms: ``write(...)`` gives the value (None or False on failure),
``write_result(...)`` a ``Result`` with the value and why it failed. ROS-free.
"""
from __future__ import annotations

from typing import Iterable, Mapping

from ..protocol import host as p
from .group_read import GroupRead
from .instructions import Instructions
from .port import SerialPort
from .reads import Reads
from .result import Result
from .stats import BusStats
from .transport import Transport
from .writes import PreparedWrite, Writes


class DynamixelBus:
    """One Protocol 2.0 serial bus (see ``Transport`` for failures and retries)."""

    def __init__(self, device: str, baudrate: int = 57600, latency_timer_ms: float = 16.0,
                 retry_num: int = 5, retry_interval_ms: float = 4.0, verbose: bool = False,
                 logger: object = None, timeout_margin_ms: float = 2.0, direct_io: bool = True) -> None:
        self._t = Transport(device, baudrate, latency_timer_ms, retry_num, retry_interval_ms, verbose, logger,
                            timeout_margin_ms, direct_io)
        self._reads = Reads(self._t)
        self._writes = Writes(self._t)
        self._one = Instructions(self._t)

    # ------------------------------------------------------------ the line
    @property
    def device(self) -> str:
        return self._t.port.device

    @property
    def baudrate(self) -> int:
        return self._t.port.baudrate

    @property
    def serial_port(self) -> SerialPort:
        """The line under the bus, for a tool that speaks Protocol 1.0 on it (the set-up tool's scan)."""
        return self._t.port

    @property
    def latency_timer_ms(self) -> float:
        """Latency used in timeouts (the configured one, or the adapter's if it is longer)."""
        return self._t.port.effective_latency_ms

    @property
    def is_open(self) -> bool:
        """True while the port is open and the device has not vanished."""
        return self._t.port.is_open

    @property
    def stats(self) -> BusStats:
        return self._t.stats

    @property
    def retry_num(self) -> int:
        return self._t.retry_num

    @property
    def retry_interval_ms(self) -> float:
        return self._t.retry_interval_ms

    @property
    def timeout_margin_ms(self) -> float:
        return self._t.rx.timeout_margin_ms

    @property
    def last_failure(self) -> str:
        """Why the latest failed call failed ("" if none yet): for a script's message; each call's
        ``Result`` carries its own."""
        return self._t.last_failure

    @property
    def last_timeout_ms(self) -> float:
        """The reply wait (ms) computed for the latest transaction."""
        return self._t.rx.last_timeout_ms

    @property
    def last_error_bytes(self) -> dict[int, int]:
        """Status error byte last reported by each servo (0x80 = hardware error present)."""
        return self._t.rx.last_error_bytes

    @property
    def firmware_versions(self) -> dict[int, int]:
        """Firmware version seen in ping replies."""
        return self._reads.firmware_versions

    @property
    def reply_lag_s(self) -> float:
        """How much later than their wire time replies arrive (learnt, seconds)."""
        return self._t.rx.reply_lag_s

    @property
    def inflight_eta(self) -> float | None:
        """``time.monotonic()`` by which the replies of the read in flight should be in, or None."""
        return self._t.inflight_eta

    @property
    def dummies(self) -> Mapping[int, object]:
        """In-process dummy servos on this bus: none (``dummy.BusWithDummies`` has them)."""
        return {}

    def reply_timeout_ms(self, tx_bytes: int, rx_bytes: int) -> float:
        """How long a reply of ``rx_bytes`` is waited for after sending ``tx_bytes``."""
        return self._t.rx.reply_timeout_ms(tx_bytes, rx_bytes)

    def open(self) -> None:
        """Open the device; BusError (what, why, what to do) if it is missing, busy, not a tty."""
        self._t.open()

    def close(self) -> None:
        self._t.close()

    def reopen(self) -> None:
        """Close and open again, e.g. after the adapter was unplugged and plugged back."""
        self._t.reopen()

    def set_baudrate(self, baudrate: int) -> None:
        self._t.set_baudrate(baudrate)

    def __enter__(self) -> DynamixelBus:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ reads
    def ping_result(self, dxl_id: int, retries: int | None = None) -> Result[int | None]:
        return self._reads.ping(dxl_id, retries)

    def ping(self, dxl_id: int, retries: int | None = None) -> int | None:
        """Model number of ``dxl_id``, or None if it does not answer."""
        return self._reads.ping(dxl_id, retries).value

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        """``{id: model_number}`` of the servos among ``ids`` that answer a ping (see ``Reads.scan``)."""
        return self._reads.scan(ids, broadcast)

    def sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> dict[int, bytes]:
        """Same item from many servos in one instruction; returns the IDs that answered (see
        ``Reads.sync_read``)."""
        return self._reads.sync_read(address, length, ids, fast)

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> GroupRead:
        """Send a sync read and return at once; ``result()`` of the returned read waits for the
        replies (``failure`` then says why when nobody answered)."""
        return self._reads.start_sync_read(address, length, ids, fast)

    def bulk_read(self, requests: Mapping[int, tuple[int, int]], fast: bool = False) -> dict[int, bytes]:
        """Different ``(address, size)`` per servo in one instruction; returns the IDs that answered."""
        return self._reads.bulk_read(requests, fast)

    def read_result(self, dxl_id: int, address: int, size: int) -> Result[bytes | None]:
        return self._one.read(dxl_id, address, size)

    def read(self, dxl_id: int, address: int, size: int) -> bytes | None:
        """``size`` raw bytes from the control table of ``dxl_id``, or None."""
        return self._one.read(dxl_id, address, size).value

    # ------------------------------------------------------------ writes
    def write_result(self, dxl_id: int, address: int, data: bytes) -> Result[bool]:
        return self._one.write(dxl_id, address, data)

    def write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Write raw bytes; True when the servo acknowledged (broadcast: when sent)."""
        return self._one.write(dxl_id, address, data).value

    def reg_write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Register a write to be executed by :meth:`action`."""
        return self._one.reg_write(dxl_id, address, data).value

    def action(self, dxl_id: int = p.BROADCAST_ID) -> bool:
        """Execute registered writes. A unicast action's status reply is read and consumed here."""
        return self._one.action(dxl_id).value

    def reboot_result(self, dxl_id: int) -> Result[bool]:
        return self._one.reboot(dxl_id)

    def reboot(self, dxl_id: int) -> bool:
        """Reboot a servo (it needs a few hundred ms before it answers again)."""
        return self._one.reboot(dxl_id).value

    def clear_multi_turn_result(self, dxl_id: int) -> Result[bool]:
        return self._one.clear_multi_turn(dxl_id)

    def clear_multi_turn(self, dxl_id: int) -> bool:
        """Reset the present position to within one turn (Clear instruction, servo must be stopped)."""
        return self._one.clear_multi_turn(dxl_id).value

    def clear_error_result(self, dxl_id: int, params: bytes) -> Result[bool]:
        """Clear a servo's error with the Clear instruction (``params``: the family's error clear)."""
        return self._one.clear_error(dxl_id, params)

    def factory_reset(self, dxl_id: int, option: int = 0x02) -> bool:
        """Factory reset; option 0xFF all, 0x01 all but ID, 0x02 (default) all but ID and baud rate."""
        return self._one.factory_reset(dxl_id, option).value

    def sync_write_result(self, address: int, length: int, data: Mapping[int, bytes]) -> Result[bool]:
        return self._writes.send_prepared(Writes.prepare_sync_write(address, length, data))

    def sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> bool:
        """Same item to many servos in one broadcast packet (no reply); True when sent."""
        return self._writes.send_prepared(Writes.prepare_sync_write(address, length, data)).value

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> PreparedWrite:
        """Check and build a sync write now, to send it later with :meth:`send_prepared` (e.g.
        while a read is on the wire). ValueError for invalid IDs or data lengths, as :meth:`sync_write`."""
        return Writes.prepare_sync_write(address, length, data)

    def send_prepared_result(self, prepared: PreparedWrite) -> Result[bool]:
        return self._writes.send_prepared(prepared)

    def send_prepared(self, prepared: PreparedWrite) -> bool:
        """Send a write built by :meth:`prepare_sync_write`; True when sent (or nothing to send)."""
        return self._writes.send_prepared(prepared).value

    def bulk_write(self, data: Mapping[int, tuple[int, bytes]]) -> bool:
        """Different ``(address, bytes)`` per servo in one broadcast packet (no reply); True when sent."""
        return self._writes.bulk_write(data).value
