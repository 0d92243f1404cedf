"""Dummy servos (``init/dummy_servo_list``): IDs handled with no hardware behind them.

Each dummy is a servo model of the virtual bus (same control table, same simple physics: it
follows its goals). The dummies are a line of their own under the one bus implementation:
``InProcessLine`` hands each packet the bus writes to the virtual bus's instruction set and keeps
the status packets for the bus to read, so a dummy is framed, answered, parsed, retried and counted
exactly as a servo on the wire. ``BusWithDummies`` stands in for the real bus: an instruction for a
dummy ID goes to the dummies' bus, everything else to the wire, and a group read or write that
names both is split between them, so dummies and real servos mix freely. A dummy wins over a real
servo of the same ID (the real one is never addressed). ROS-free.
"""
from __future__ import annotations

import collections
import time
from typing import Any, Iterable, Mapping, Sequence

from .bus import BusStats, DynamixelBus, Failure, GroupRead, PreparedWrite, Result
from .bus.ops import BulkRead, BulkWrite, ErrorByte, Instruction, Ping, Read, SyncRead
from .control_table import family_named, model_by_number
from .protocol import servo as wire
from .sim.instructions import InstructionSet
from .sim.servo import VirtualServo

#: the dummies' line: no adapter between host and servos
DEVICE = "in-process dummy servos"


def make_dummies(ids: Iterable[int], series: str | Sequence[str]) -> dict[int, VirtualServo]:
    """Dummies of one series, or of the series given per ID (``ServoFamily.dummy_model``: XM430-W350,
    PH54-200-S500-R, H54-200-S500-R)."""
    ids = list(ids)
    per_id = [series] * len(ids) if isinstance(series, str) else list(series)
    return {i: VirtualServo(model_by_number(family_named(s).dummy_model), i, time.monotonic) for i, s in zip(ids, per_id)}


class InProcessLine:
    """A ``bus.line.Line`` whose servos answer in this process at once: no wire time, no latency."""

    effective_latency_ms = 0.0
    tx_ms_per_byte = 0.0

    def __init__(self, servos: Iterable[VirtualServo], baudrate: int = 57600) -> None:
        self.device = DEVICE
        self.baudrate = baudrate
        self.lost = False
        self._open = False
        self._servos = list(servos)
        self._instructions = InstructionSet(self._servos, time.monotonic, collections.deque(maxlen=64),
                                            collections.Counter(), collections.deque(maxlen=64))
        self._parser = wire.PacketParser()
        self._input = bytearray()

    @property
    def is_open(self) -> bool:
        return self._open

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False

    def set_baudrate(self, baudrate: int) -> None:
        self.baudrate = baudrate

    def discard_input(self) -> int:
        dropped = len(self._input)
        self._input.clear()
        return dropped

    def waiting(self) -> int:
        return len(self._input)

    def write(self, packet: bytes) -> None:
        """The servos execute each whole packet now; their status packets wait to be read."""
        for instruction in self._parser.feed(packet):
            for _delay, status in self._instructions.execute(instruction):
                self._input += status

    def read_until(self, deadline: float, expect: int = 0, due: float | None = None) -> bytes:
        """What the servos answered (nothing more will come: b"" is the deadline reached)."""
        data = bytes(self._input)
        self._input.clear()
        return data


class BusWithDummies:
    """The bus API of ``DynamixelBus`` over the wire plus the dummies' own ``DynamixelBus``."""

    def __init__(self, bus: DynamixelBus, dummies: Mapping[int, VirtualServo]) -> None:
        self._bus = bus
        self.dummies = dict(dummies)
        self._dummy_bus = DynamixelBus(DEVICE, bus.baudrate, retry_num=0, line=InProcessLine(self.dummies.values()))
        self._dummy_bus.open()

    # ------------------------------------------------------------ the real bus's own parts
    @property
    def device(self) -> str:
        return self._bus.device

    @property
    def baudrate(self) -> int:
        return self._bus.baudrate

    @property
    def latency_timer_ms(self) -> float:
        return self._bus.latency_timer_ms

    @property
    def inflight_eta(self) -> float | None:
        return self._bus.inflight_eta

    @property
    def stats(self) -> BusStats:
        return self._bus.stats

    @property
    def is_open(self) -> bool:
        return self._bus.is_open

    def open(self) -> None:
        self._bus.open()

    def close(self) -> None:
        self._bus.close()

    def reopen(self) -> None:
        self._bus.reopen()

    def set_baudrate(self, baudrate: int) -> None:
        self._bus.set_baudrate(baudrate)

    # ------------------------------------------------------------ instructions
    def execute(self, instruction: Instruction) -> Result[Any]:
        """As ``DynamixelBus.execute``: an instruction to a dummy goes to the dummies' bus, a group
        read or write that names dummies and real servos is split between the two buses."""
        op = instruction
        if isinstance(op, PreparedWrite):
            return self._send_prepared(op)
        if isinstance(op, SyncRead):
            return self._sync_read(op)
        if isinstance(op, BulkRead):
            real, dummy = self._split_map(op.requests)
            return _joined(self._on_wire(BulkRead(real, op.fast, protocol=op.protocol), {}) if real else Result({}),
                           self._dummy_bus.execute(BulkRead(dummy, protocol=2)) if dummy else Result({}), "bulk read")
        if isinstance(op, BulkWrite):
            real, dummy = self._split_map(op.data)
            done = self._dummy_bus.execute(BulkWrite(dummy)) if dummy else _DONE
            return self._on_wire(BulkWrite(real), False) if real else done
        if op.dxl_id in self.dummies:
            return self._dummy_bus.execute(op)
        return self._on_wire(op, None if isinstance(op, (Ping, ErrorByte, Read)) else False)

    def _on_wire(self, op: Instruction, failed: object) -> Result[Any]:
        """``op`` on the wire; at once a failure (``failed`` its value) while the wire is closed or gone."""
        if not self._bus.is_open:
            return Result(failed, Failure.PORT_CLOSED, f"{_what(op)}: port closed or device lost")
        return self._bus.execute(op)

    def _split(self, ids: Iterable[int]) -> tuple[list[int], list[int]]:
        real: list[int] = []
        dummy: list[int] = []
        for i in ids:
            (dummy if i in self.dummies else real).append(i)
        return real, dummy

    def _split_map(self, per_id: Mapping[int, Any]) -> tuple[dict[int, Any], dict[int, Any]]:
        real, dummy = self._split(per_id)
        return {i: per_id[i] for i in real}, {i: per_id[i] for i in dummy}

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        real, dummy = self._split(ids)
        found = self._bus.scan(real, broadcast) if (real and self._bus.is_open) else {}
        found.update(self._dummy_bus.scan(dummy, broadcast) if dummy else {})
        return dict(sorted(found.items()))

    # ------------------------------------------------------------ groups
    def _sync_read(self, op: SyncRead) -> Result[dict[int, bytes]]:
        real, dummy = self._split(op.ids)
        wire_part: Result[Any] = Result({})
        if real:
            wire_part = self._on_wire(SyncRead(op.address, op.length, tuple(real), op.fast, protocol=op.protocol), {})
        dummy_part = self._dummy_bus.execute(SyncRead(op.address, op.length, tuple(dummy), protocol=2)) if dummy else Result({})
        return _joined(wire_part, dummy_part, f"sync read @{op.address}x{op.length}")

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        *, protocol: int) -> GroupRead:
        """As ``DynamixelBus.start_sync_read``; a read that includes dummies is done at once."""
        ids = list(ids)
        real, dummy = self._split(ids)
        if not dummy and self._bus.is_open:
            return self._bus.start_sync_read(address, length, real, fast, protocol=protocol)
        done = self._sync_read(SyncRead(address, length, tuple(ids), fast, protocol=protocol))
        read = GroupRead.finished(done.value)
        read.failure, read.why = done.failure, done.why
        return read

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes], *, protocol: int) -> PreparedWrite:
        """As ``DynamixelBus.prepare_sync_write``; the dummies' part is written when it is sent."""
        real, dummy = self._split_map(data)
        prepared = self._bus.prepare_sync_write(address, length, real, protocol=protocol)
        return PreparedWrite(prepared.address, prepared.length, prepared.ids, prepared.packet,
                             {i: bytes(d) for i, d in dummy.items()}) if dummy else prepared

    def _send_prepared(self, prepared: PreparedWrite) -> Result[bool]:
        mine = {i: d for i, d in prepared.dummies.items() if i in self.dummies}
        if mine:
            self._dummy_bus.execute(self._dummy_bus.prepare_sync_write(prepared.address, prepared.length, mine,
                                                                                protocol=2))
        if not prepared.packet:
            return _DONE
        return self._on_wire(PreparedWrite(prepared.address, prepared.length, prepared.ids, prepared.packet), False)


_DONE: Result[bool] = Result(True)


def _joined(wire_part: Result[Any], dummy_part: Result[Any], what: str) -> Result[dict[int, bytes]]:
    """The replies of a group read split between the wire and the dummies, as one read's result."""
    out = {**dict(wire_part.value or {}), **dict(dummy_part.value or {})}
    if out:
        return Result(out)
    failure = wire_part.failure or dummy_part.failure
    return Result(out, failure or Failure.NOBODY_ANSWERED, wire_part.why or dummy_part.why or f"{what}: no servo answered")


def _what(op: Instruction) -> str:
    """An instruction as a log line names it: "read ID 3 @132x4", "sync write @116x4"."""
    if isinstance(op, PreparedWrite):
        return f"sync write @{op.address}x{op.length}"
    name = _NAMES.get(type(op).__name__, type(op).__name__)
    where = f" ID {op.dxl_id}" if hasattr(op, "dxl_id") else ""
    return name + (where + f" @{op.address}x{op.size}" if isinstance(op, Read) else where)


_NAMES = {"Ping": "ping", "Read": "read", "Write": "write", "Reboot": "reboot", "ClearMultiTurn": "clear multi-turn",
          "ClearError": "error clear", "BulkRead": "bulk read", "BulkWrite": "bulk write"}
