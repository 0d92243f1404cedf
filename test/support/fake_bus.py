"""A bus in memory for unit tests of the core's parts (``test/core``): each servo a register image
of its model, every call the core makes recorded in order, and switches for the faults a part
must survive (silent servos, firmware without Fast Sync Read, failing sync writes, a device gone).

It answers as the servos would (values written are read back; a silent servo answers nothing)
but has no timing, no wire and no physics: the virtual bus (``dynamixel_handler.sim``) is the
real peer for those."""
from __future__ import annotations

import dataclasses
from typing import Any, Iterable, Mapping

from dynamixel_handler import units
from dynamixel_handler.bus import GroupRead, PreparedWrite
from dynamixel_handler.bus.ops import ErrorByte, Ping, Read, Reboot, SyncRead, Write
from dynamixel_handler.bus.result import Failure, Result
from dynamixel_handler.bus.stats import BusStats
from dynamixel_handler.control_table import Model, model_by_number, protocol1_model_by_number
from dynamixel_handler.servo.table import ServoTable

XM430, XM540, PH54, H54 = 1020, 1130, 2020, 54024
MEMORY = 1024


@dataclasses.dataclass(frozen=True)
class FakePrepared(PreparedWrite):
    data: Mapping[int, bytes] = dataclasses.field(default_factory=dict)


class FakeBus:
    """Servos ``{ID: model number}``; ``calls`` lists ``(kind, ...)`` tuples:
    ``("ping", id)``, ``("read", id, address, size)``, ``("write", id, address, data)``,
    ``("reboot", id)``, ``("sync_read", address, length, ids, fast)``,
    ``("sync_write", address, length, {id: data})``."""

    def __init__(self, servos: Mapping[int, int], baudrate: int = 57600, latency_timer_ms: float = 1.0,
                 protocol1: Mapping[int, int] | None = None) -> None:
        self.models: dict[int, Model] = {i: model_by_number(n) for i, n in servos.items()}
        #: Protocol 1.0 servos ``{ID: model number}``: they answer Protocol 1.0 instructions only
        self.models.update({i: protocol1_model_by_number(n) for i, n in (protocol1 or {}).items()})
        self.memory = {i: bytearray(MEMORY) for i in self.models}
        self.baudrate = baudrate
        self.latency_timer_ms = latency_timer_ms
        self.device = "fake"
        self.stats = BusStats()
        self.dummies: dict[int, object] = {}
        self.inflight_eta: float | None = None
        self.is_open = True
        self.can_reopen = True
        self.calls: list[tuple[Any, ...]] = []
        self.silent: set[int] = set()          # answer nothing
        self.no_fast: set[int] = set()         # answer Sync Read, not Fast Sync Read (old firmware)
        self.fail_sync_writes = False          # sync writes are not sent ("no adapter")
        self.errors: dict[int, int] = {}       # Protocol 1.0: the error byte of a servo's statuses
        for i, model in self.models.items():
            self.set(i, "model_number", model.number)

    # ---------------------------------------------------------------- the test's side
    def set(self, dxl_id: int, item: str, value: int) -> None:
        spec = self.models[dxl_id].item(item)
        self.memory[dxl_id][spec.address:spec.address + spec.size] = units.encode(spec, [value])

    def get(self, dxl_id: int, item: str) -> int:
        spec = self.models[dxl_id].item(item)
        return int(units.decode(spec, bytes(self.memory[dxl_id][spec.address:spec.address + spec.size]))[0])

    def of(self, kind: str) -> list[tuple[Any, ...]]:
        """The calls of one kind, in order."""
        return [c for c in self.calls if c[0] == kind]

    def item_writes(self) -> list[tuple[str, Any, Any]]:
        """Every write as ``(kind, item, value)``: ``("write", item, (id, value))`` for one servo,
        ``("sync_write", item, {id: value})`` for a sync write of one item."""
        out: list[tuple[str, Any, Any]] = []
        for call in self.calls:
            if call[0] == "write":
                _, dxl_id, address, data = call
                item = self._item_at(dxl_id, address, len(data))
                spec = self.models[dxl_id].item(item) if item else None
                out.append(("write", item, (dxl_id, int(units.decode(spec, data)[0]) if spec else data)))
            elif call[0] == "sync_write":
                _, address, length, data = call
                first = min(data) if data else None
                item = self._item_at(first, address, length) if first is not None else None
                spec = self.models[first].item(item) if item else None
                out.append(("sync_write", item, {i: int(units.decode(spec, d)[0]) if spec else d for i, d in data.items()}))
        return out

    def _item_at(self, dxl_id: int, address: int, size: int) -> str | None:
        for name, spec in self.models[dxl_id].items.items():
            if spec.address == address and spec.size == size:
                return name
        return None

    # ---------------------------------------------------------------- ServoBus
    def _answers(self, dxl_id: int, protocol: int = 2) -> bool:
        return (self.is_open and dxl_id in self.memory and dxl_id not in self.silent
                and self.models[dxl_id].protocol == protocol)

    def open(self) -> None:
        self.is_open = True

    def close(self) -> None:
        self.is_open = False

    def reopen(self) -> None:
        self.calls.append(("reopen",))
        if not self.can_reopen:
            raise OSError("still gone")
        self.is_open = True

    def execute(self, op: Any) -> Result[Any]:
        """The one door of ``ServoBus``: each instruction value recorded and answered."""
        kind = type(op)
        if kind is FakePrepared:
            return self._sync_write(op)
        if kind is SyncRead:
            data = self._sync_read(op.address, op.length, op.ids, op.fast)
            return Result(data) if data or not op.ids else Result(data, Failure.NOBODY_ANSWERED, "no servo answered")
        dxl_id = op.dxl_id
        if kind is Ping:
            self.calls.append(("ping", dxl_id) if op.protocol == 2 else ("ping1", dxl_id))
            return Result(self.models[dxl_id].number) if self._answers(dxl_id, op.protocol) else _no_reply(None)
        if kind is Read:
            self.calls.append(("read", dxl_id, op.address, op.size))
            if not self._answers(dxl_id, op.protocol):
                return _no_reply(None)
            return Result(bytes(self.memory[dxl_id][op.address:op.address + op.size]))
        if kind is Write:
            self.calls.append(("write", dxl_id, op.address, op.data))
            if not self._answers(dxl_id, op.protocol):
                return _no_reply(False)
            self.memory[dxl_id][op.address:op.address + len(op.data)] = op.data
            return Result(True)
        if kind is ErrorByte:
            self.calls.append(("error_byte", dxl_id))
            return Result(self.errors.get(dxl_id, 0)) if self._answers(dxl_id, op.protocol) else _no_reply(None)
        if kind is Reboot:
            self.calls.append(("reboot", dxl_id))
            return Result(True) if self._answers(dxl_id, op.protocol) else _no_reply(False)
        raise AssertionError(f"the fake bus does not take {op!r}")

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        ids = list(ids)
        self.calls.append(("scan", tuple(ids)))
        return {i: self.models[i].number for i in ids if self._answers(i)}  # a broadcast ping: Protocol 2.0

    def _sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> dict[int, bytes]:
        ids = tuple(ids)
        self.calls.append(("sync_read", address, length, ids, fast))
        out = {}
        for dxl_id in ids:
            if not self._answers(dxl_id) or (fast and dxl_id in self.no_fast):
                if fast:
                    break  # a fast read's chain stops at the first servo that does not answer
                continue
            out[dxl_id] = bytes(self.memory[dxl_id][address:address + length])
        return out

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        protocol: int = 2) -> GroupRead:
        return GroupRead.finished(self._sync_read(address, length, ids, fast))

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes], protocol: int = 2) -> PreparedWrite:
        return FakePrepared(address, length, tuple(sorted(data)), b"", {}, dict(data))

    def _sync_write(self, prepared: FakePrepared) -> Result[bool]:
        self.calls.append(("sync_write", prepared.address, prepared.length, dict(prepared.data)))
        if self.fail_sync_writes or not self.is_open:
            return Result(False, Failure.DEVICE_LOST, "the adapter is gone")
        for dxl_id, chunk in prepared.data.items():
            if self._answers(dxl_id):
                self.memory[dxl_id][prepared.address:prepared.address + len(chunk)] = chunk
        return Result(True)


def _no_reply(value: Any) -> Result[Any]:
    return Result(value, Failure.NO_REPLY, "no reply")


def table_of(bus: FakeBus, ids: Iterable[int] | None = None) -> ServoTable:
    """A servo table handling ``ids`` (default: every servo of ``bus``) with their models."""
    table = ServoTable()
    for dxl_id in sorted(bus.models if ids is None else ids):
        table.add(dxl_id, bus.models[dxl_id])
    return table
