"""One item of many servos in one transaction per control-table layout: a sync write or sync read
over all of them instead of one transaction per servo (on a slow bus, 20 servos at 9600 bps, the
difference between the wire time of one packet and of twenty)."""
from __future__ import annotations

from typing import Iterable, Mapping

from .. import units
from ..bus import ServoBus
from ..bus.ops import SyncRead
from ..servos import ServoTable
from .servo_io import Log


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
            written = self.bus.execute(self.bus.prepare_sync_write(address, size, data, protocol))
            if written:
                for dxl_id in members:
                    self.table.set_value(item, dxl_id, values[dxl_id])
            else:
                self.log.warning(f"{what}: writing {item} to IDs {members} failed: {written.why}")
