"""Pending writes -> one sync write per item (adjacent items merged), built ahead, sent in one go."""
from __future__ import annotations

import numpy as np

from ..bus import PreparedWrite, ServoBus
from ..logs import Throttle
from ..servo.table import PendingWrites, ServoTable
from .servo_io import Log

#: one sync write: (address, size, protocol)
WriteKey = tuple[int, int, int]


class WriteBatch:
    """The pending values as prepared sync writes; nothing taken is lost when a loop fails.
    ``split_write`` (method/split_write): one sync write per item, adjacent items not merged."""

    def __init__(self, bus: ServoBus, table: ServoTable, pending: PendingWrites, log: Log,
                 split_write: bool = False) -> None:
        self.bus = bus
        self.table = table
        self.pending = pending
        self.log = log
        self.split_write = split_write
        # writes taken from ``pending`` but not sent yet (encode_writes): {(address, size): {id: bytes}}
        # per item, and their packets, built for ServoTable.version ``_built_for``. Kept here, not in a
        # StepReport, so that a loop that fails between taking and sending them loses nothing.
        self._taken: dict[WriteKey, dict[int, bytes]] = {}
        self._prepared: list[PreparedWrite] = []
        self._built_for = -1
        #: failed sync writes: one line a second per item and reason (a vanished device fails every loop's)
        self._write_failures = Throttle(lambda msg: self.log.warning(msg))

    def send(self) -> None:
        """What is pending (and what ``encode_writes`` took before) goes on the wire."""
        self.encode_writes()
        if self._taken and self._built_for != self.table.version:  # servos removed meanwhile
            self._build_writes()
        prepared, self._prepared, self._taken = self._prepared, [], {}
        for write in prepared:
            sent = self.bus.execute(write)
            if not sent:
                reason = str(sent.failure) if sent.failure else sent.why  # the bus's why names the write again
                self._write_failures(f"sync write @{write.address}x{write.length} to IDs "
                                     f"{sorted((*write.ids, *write.dummies))} failed: {reason}",
                                     key=f"{write.address}x{write.length} {reason}")

    def encode_writes(self) -> None:
        """Take the pending values and build their sync write packets now; the next
        ``send_writes`` sends them (with what became pending meanwhile, a later value of a servo's
        item winning). The node does this while a read is on the wire, so the packets are ready the
        moment it is free."""
        fresh = self._encode_pending()
        if not fresh:
            return
        for key, data in fresh.items():
            self._taken.setdefault(key, {}).update(data)
        self._build_writes()

    @property
    def writes_ready(self) -> list[PreparedWrite]:
        """The sync writes built by ``encode_writes`` and not sent yet (``PreparedWrite``)."""
        return list(self._prepared)

    def _build_writes(self) -> None:
        index = self.table.index
        writes = {key: kept for key, data in self._taken.items()
                  if (kept := {i: chunk for i, chunk in data.items() if i in index})}
        if not self.split_write:
            writes = _merge_adjacent_writes(writes)
        self._prepared = [self.bus.prepare_sync_write(address, size, data, protocol=protocol)
                          for (address, size, protocol), data in sorted(writes.items())]
        self._built_for = self.table.version

    def _encode_pending(self) -> dict[WriteKey, dict[int, bytes]]:
        """The pending values as one sync write per item and protocol ``{(address, size, protocol):
        {id: bytes}}``; the table takes them."""
        pending = self.pending.take()
        if not pending or not len(self.table):
            return {}
        # (address, size) -> {item: {id: pulses}}: one sync write per item and layout
        writes: dict[WriteKey, dict[int, bytes]] = {}
        index = self.table.index
        for item, values in pending.items():
            positions, written = [], []
            for dxl_id, pulses in values.items():
                pos = index.get(dxl_id)
                if pos is None:
                    continue
                model = self.table.models[pos]
                spec = model.items.get(item)
                if spec is None:
                    continue
                try:
                    data = spec.to_bytes(int(pulses))
                except OverflowError:
                    self.log.error(f"ID {dxl_id}: {item}={pulses} does not fit its {spec.size} bytes: not written")
                    continue
                writes.setdefault((spec.address, spec.size, model.protocol), {})[dxl_id] = data
                positions.append(pos)
                written.append(pulses)
            if positions:
                self.table.store(item, np.asarray(positions), np.asarray(written, dtype=np.int64),
                                 self.table.read_time.get(item, 0.0))
                self.table.note_set(item, [self.table.ids[pos] for pos in positions])
        return writes



def _merge_adjacent_writes(writes: dict[WriteKey, dict[int, bytes]]) -> dict[WriteKey, dict[int, bytes]]:
    """Join writes of back-to-back items that go to the same IDs (of one protocol) into one sync write."""
    merged: dict[WriteKey, dict[int, bytes]] = {}
    last: WriteKey | None = None
    for (address, size, protocol), data in sorted(writes.items(), key=lambda kv: (kv[0][2], kv[0][0])):
        if (last is not None and last[2] == protocol and last[0] + last[1] == address
                and set(merged[last]) == set(data)):
            joined = {i: merged[last][i] + data[i] for i in data}
            del merged[last]
            last = (last[0], last[1] + size, protocol)
            merged[last] = joined
        else:
            last = (address, size, protocol)
            merged[last] = dict(data)
    return merged
