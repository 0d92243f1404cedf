"""DynamixelBus: every transaction the handler needs, in Protocol 2.0 or 1.0 (the framer of each
instruction's protocol), with retries and counters.

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
One door for instructions: ``execute(instruction)`` takes a value of :mod:`.ops` (``Read(1, 132,
4)``, ``SyncRead(...)``, a prepared sync write ...) and gives one ``Result`` (the value, the
``Failure`` kind and why in words); beside it the operations that are more than one instruction
or leave one on the wire: ``scan``, ``start_sync_read``, ``prepare_sync_write``. ROS-free.
"""
from __future__ import annotations

from typing import Any, Iterable, Mapping, Protocol

from ..protocol.framers import FRAMERS
from .group_read import GroupRead
from .instructions import Instructions
from .line import Line
from .ops import (
    BulkRead,
    BulkWrite,
    Instruction,
    Ping,
    SyncRead,
)
from .reads import Reads
from .receive import Receiver
from .result import Result
from .stats import BusStats
from .transport import Transport
from .writes import PreparedWrite, Writes


class LineSettings(Protocol):
    """What a bus is built from (``settings.BusSettings`` has these fields)."""

    @property
    def baudrate(self) -> int: ...
    @property
    def latency_ms(self) -> int: ...
    @property
    def retries(self) -> int: ...
    @property
    def retry_interval_ms(self) -> float: ...
    @property
    def verbose(self) -> bool: ...


class DynamixelBus:
    """One serial bus of Dynamixel servos, Protocol 2.0 and 1.0 (see ``Transport`` for failures
    and retries)."""

    @classmethod
    def of(cls, device: str, settings: LineSettings, logger: object = None) -> DynamixelBus:
        """The bus on ``device`` as typed settings say (``settings.BusSettings``: the node's
        ``baudrate``, ``latency_timer`` (at least 1 ms), ``dyn_comm/*``)."""
        return cls(device, settings.baudrate, max(1.0, float(settings.latency_ms)), settings.retries,
                   settings.retry_interval_ms, verbose=settings.verbose, logger=logger)

    def __init__(self, device: str, baudrate: int = 57600, latency_timer_ms: float = 16.0,
                 retry_num: int = 5, retry_interval_ms: float = 4.0, verbose: bool = False,
                 logger: object = None, timeout_margin_ms: float = 2.0, direct_io: bool = True,
                 line: Line | None = None) -> None:
        self._t = Transport(device, baudrate, latency_timer_ms, retry_num, retry_interval_ms, verbose, logger,
                            timeout_margin_ms, direct_io, line)
        self._reads = Reads(self._t)
        self._writes = Writes(self._t)
        self._one = Instructions(self._t)
        #: the device the bus was made for (its line's path; the line may be reopened, never changed)
        self.device = self._t.port.device
        #: the line under the bus (its backend), for a tool that writes its own packets on it (the
        #: set-up tool's Protocol 1.0 scan, its trace)
        self.line: Line = self._t.port
        #: the counters of every transaction
        self.stats: BusStats = self._t.stats
        #: the line's timing: the reply wait of a transaction (``reply_timeout_ms``), the one computed
        #: for the latest (``last_timeout_ms``), the margin, how late replies come
        self.timing: Receiver = self._t.rx
        #: the firmware version seen in Protocol 2.0 ping replies (a Protocol 1.0 status has none)
        self.firmware_versions: dict[int, int] = self._reads.firmware_versions

    # ------------------------------------------------------------ the line
    @property
    def baudrate(self) -> int:
        return self._t.port.baudrate

    @property
    def latency_timer_ms(self) -> float:
        """Latency used in timeouts (the configured one, or the adapter's if it is longer)."""
        return self._t.port.effective_latency_ms

    @property
    def is_open(self) -> bool:
        """True while the port is open and the device has not vanished."""
        return self._t.port.is_open

    @property
    def inflight_eta(self) -> float | None:
        """``time.monotonic()`` by which the replies of the read in flight should be in, or None."""
        return self._t.inflight_eta

    @property
    def dummies(self) -> Mapping[int, object]:
        """In-process dummy servos on this bus: none (``dummy.BusWithDummies`` has them)."""
        return {}

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

    # ------------------------------------------------------------ instructions
    def execute(self, instruction: Instruction) -> Result[Any]:
        """Send one instruction (a value of :mod:`.ops`) and give its ``Result``: an instruction to
        one servo frames itself (``Instructions.execute``), a group one goes to its part."""
        match instruction:
            case Ping():
                return self._reads.ping(instruction.dxl_id, instruction.retries, framer=FRAMERS[instruction.protocol])
            case SyncRead():
                op = instruction
                return self._group(self._reads.start_sync_read(op.address, op.length, op.ids, op.fast, protocol=op.protocol))
            case BulkRead():
                return self._group(self._reads.bulk_read(instruction.requests, instruction.fast,
                                                         framer=FRAMERS[instruction.protocol]))
            case BulkWrite():
                return self._writes.bulk_write(instruction.data)
            case PreparedWrite():
                return self._writes.send_prepared(instruction)
            case _:
                return self._one.execute(instruction, FRAMERS[instruction.protocol])

    def _group(self, read: GroupRead) -> Result[dict[int, bytes]]:
        data = read.result()
        return Result(data, read.failure, read.why)

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        """``{id: model_number}`` of the servos among ``ids`` that answer a ping (see ``Reads.scan``)."""
        return self._reads.scan(ids, broadcast)

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        *, protocol: int) -> GroupRead:
        """Send a sync read and return at once; ``result()`` of the returned read waits for the
        replies (``failure`` then says why when nobody answered). Meanwhile the caller may do work
        that needs no bus; any other transaction first waits for this read to end. Protocol 1.0
        servos have no Sync Read: each is read on its own, and the read is done when it returns."""
        return self._reads.start_sync_read(address, length, ids, fast, protocol=protocol)

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes], *, protocol: int) -> PreparedWrite:
        """Check and build a sync write (in ``protocol``) now, to send it later with ``execute``
        (e.g. while a read is on the wire, so the packet is ready the moment the line is free).
        ValueError for invalid IDs or data lengths."""
        return Writes.prepare_sync_write(address, length, data, protocol=protocol)
