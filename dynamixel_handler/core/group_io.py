"""One item of many servos in one transaction per control-table layout: a sync write or sync read
over all of them instead of one transaction per servo (on a slow bus, 20 servos at 9600 bps, the
difference between the wire time of one packet and of twenty)."""
from __future__ import annotations

from typing import Iterable, Mapping, Sequence

from .. import units
from ..bus import ServoBus
from ..bus.ops import SyncRead
from ..control_table import Item, Model
from ..servo.table import ServoTable
from .servo_io import Log

#: items farther apart than this many bytes are read in separate sync reads (not one long span)
SPAN_GAP = 32


class GroupIO:
    """``read_group`` / ``write_group``: kept in the servo table like the one-servo reads and writes."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log) -> None:
        self.bus = bus
        self.table = table
        self.log = log

    def _layouts(self, item: str, ids: Iterable[int]) -> dict[tuple[int, int, int], list[int]]:
        """The servos of ``ids`` that have ``item``, by its (address, size) in their model and their protocol."""
        out: dict[tuple[int, int, int], list[int]] = {}
        for dxl_id in ids:
            model = self.table.model(dxl_id)
            if model.has(item):
                spec = model.item(item)
                out.setdefault((spec.address, spec.size, model.protocol), []).append(dxl_id)
        return out

    def read_group(self, item: str, ids: Iterable[int]) -> dict[int, int]:
        """``item`` of the servos that answered, one sync read per layout; kept in the table."""
        values: dict[int, int] = {}
        for (address, size, protocol), members in self._layouts(item, ids).items():
            replies = self.bus.execute(SyncRead(address, size, tuple(members), protocol=protocol)).value
            for dxl_id, data in replies.items():
                spec = self.table.model(dxl_id).item(item)
                values[dxl_id] = int(units.decode(spec, data)[0])
                self.table.set_value(item, dxl_id, values[dxl_id])
        return values

    def write_group(self, item: str, values: Mapping[int, int], what: str = "shutdown") -> None:
        """``item`` := ``values`` ({ID: pulses}), one sync write per layout; kept in the table."""
        for (address, size, protocol), members in self._layouts(item, values).items():
            data = {i: units.encode(self.table.model(i).item(item), [values[i]]) for i in members}
            written = self.bus.execute(self.bus.prepare_sync_write(address, size, data, protocol=protocol))
            if written:
                for dxl_id in members:
                    self.table.set_value(item, dxl_id, values[dxl_id])
            else:
                self.log.warning(f"{what}: writing {item} to IDs {members} failed: {written.why}")

    def read_items(self, items: Sequence[str], ids: Iterable[int]) -> dict[int, dict[str, int]]:
        """{ID: {item: value}} of the ``items`` each servo of ``ids`` has, for a snapshot (not kept
        in the table): one sync read per control-table layout over each span of them (items less
        than ``SPAN_GAP`` bytes apart share one), not a read per item; a servo that did not answer
        a span lacks its items."""
        spans: dict[tuple[int, int, int, tuple[tuple[str, int, int], ...]], list[int]] = {}
        for dxl_id in ids:
            model = self.table.model(dxl_id)
            for start, length, layout in _spans(model, items):
                spans.setdefault((start, length, model.protocol, layout), []).append(dxl_id)
        out: dict[int, dict[str, int]] = {}
        for (start, length, protocol, layout), members in spans.items():
            replies = self.bus.execute(SyncRead(start, length, tuple(members), protocol=protocol)).value
            for dxl_id, data in replies.items():
                model = self.table.model(dxl_id)
                out.setdefault(dxl_id, {}).update(
                    {name: int(units.decode(model.item(name), data[a - start:a - start + n])[0]) for name, a, n in layout})
        return out


def _spans(model: Model, items: Sequence[str]) -> list[tuple[int, int, tuple[tuple[str, int, int], ...]]]:
    """The model's ``items`` as (start address, length, ((item, address, size), ...)) spans."""
    specs = sorted((model.item(n) for n in set(items) if model.has(n)), key=lambda spec: spec.address)
    out: list[tuple[int, int, tuple[tuple[str, int, int], ...]]] = []
    group: list[Item] = []
    for spec in specs:
        if group and spec.address - max(g.address + g.size for g in group) > SPAN_GAP:
            out.append(_span(group))
            group = []
        group.append(spec)
    return out + ([_span(group)] if group else [])


def _span(group: list[Item]) -> tuple[int, int, tuple[tuple[str, int, int], ...]]:
    start = group[0].address
    end = max(g.address + g.size for g in group)
    return start, end - start, tuple((g.name, g.address, g.size) for g in group)
