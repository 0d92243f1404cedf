"""A bus in memory for unit tests of the core's parts (``test/core``): the real ``DynamixelBus``
over a ``support.memory_line.MemoryLine``, each servo a raw register image of its model, every
instruction that reaches the line recorded in order, and switches for the faults a part must survive
(silent servos, firmware without Fast Sync Read, failing sync writes, a device gone).

The servos answer as servos would (values written are read back; a silent servo answers nothing)
and the bus frames, parses and counts every instruction as on the wire, with no retries (the
bus's ``retry_num`` is 0: one packet per instruction), no timing and no physics: the virtual bus
(``dynamixel_handler.sim``) is the real peer for those."""
from __future__ import annotations

from typing import Any, Iterable, Mapping

from dynamixel_handler import units
from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.control_table import Model, model_by_number, protocol1_model_by_number
from dynamixel_handler.servo.table import ServoTable

from .memory_line import MemoryLine

XM430, XM540, PH54, H54 = 1020, 1130, 2020, 54024


def _switch(name: str, doc: str) -> property:
    """A switch of the line, read and set on the bus as the tests always have."""
    return property(lambda self: getattr(self.memory_line, name),
                    lambda self, value: setattr(self.memory_line, name, value), doc=doc)


class FakeBus(DynamixelBus):
    """Servos ``{ID: model number}`` (``protocol1``: Protocol 1.0 servos, which answer Protocol 1.0
    instructions only) on a ``DynamixelBus`` over a ``MemoryLine``. ``calls`` lists one tuple per
    instruction packet (as ``memory_line`` decodes it): ``("ping", id)`` (``"ping1"`` in Protocol 1.0; a
    broadcast ping is ``("ping", 254)``), ``("read", id, address, size)``,
    ``("write", id, address, data)``, ``("reboot", id)``, ``("sync_read", address, length, ids, fast)``,
    ``("sync_write", address, length, {id: data})``, ``("bulk_read", {id: (address, size)}, fast)``;
    and ``("scan", ids)`` for each scan the bus was asked for, before its pings."""

    silent = _switch("silent", "IDs that answer nothing")
    no_fast = _switch("no_fast", "IDs that answer Sync Read, not Fast Sync Read (old firmware)")
    fail_sync_writes = _switch("fail_sync_writes", "sync writes fail as the serial port's write does "
                                                   "when the adapter is gone (the bus then takes the device as lost)")
    errors = _switch("errors", "Protocol 1.0: the error bits of an ID's statuses")
    can_reopen = _switch("can_reopen", "False: opening the line fails as for a missing device")
    calls = _switch("calls", "one tuple per instruction that reached the line")

    def __init__(self, servos: Mapping[int, int], baudrate: int = 57600, latency_timer_ms: float = 1.0,
                 protocol1: Mapping[int, int] | None = None) -> None:
        self.models: dict[int, Model] = {i: model_by_number(n) for i, n in servos.items()}
        self.models.update({i: protocol1_model_by_number(n) for i, n in (protocol1 or {}).items()})
        self.memory_line = MemoryLine(self.models, baudrate, latency_timer_ms)
        #: each servo's register image
        self.memory = {i: servo.memory for i, servo in self.memory_line.servos.items()}
        super().__init__(self.memory_line.device, baudrate, latency_timer_ms, retry_num=0, retry_interval_ms=0.0,
                         line=self.memory_line)
        self.open()
        for i, model in self.models.items():
            self.set(i, "model_number", model.number)

    @property  # type: ignore[override]
    def is_open(self) -> bool:
        """True while the line is open and the device has not gone; set False, the device is gone
        (as the bus leaves its line when a transaction found it so); set True, it is back."""
        return self.memory_line.is_open

    @is_open.setter
    def is_open(self, value: bool) -> None:
        if value:
            self.memory_line.open()
        else:
            self.memory_line.lost = True
            self.memory_line.close()

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
        if dxl_id not in self.models:
            return None
        for name, spec in self.models[dxl_id].items.items():
            if spec.address == address and spec.size == size:
                return name
        return None

    # ---------------------------------------------------------------- the bus
    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        """The bus's scan, noted as ``("scan", ids)`` before the pings it sends."""
        ids = list(ids)
        self.calls.append(("scan", tuple(ids)))
        return super().scan(ids, broadcast)


def table_of(bus: FakeBus, ids: Iterable[int] | None = None) -> ServoTable:
    """A servo table handling ``ids`` (default: every servo of ``bus``) with their models."""
    table = ServoTable()
    for dxl_id in sorted(bus.models if ids is None else ids):
        table.add(dxl_id, bus.models[dxl_id])
    return table
