"""Group writes of ``DynamixelBus``: sync write (also built ahead and sent later) and bulk write;
broadcast packets, no reply."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping

from ..protocol import host as p
from .group_read import check_id
from .transport import Transport


@dataclass(frozen=True)
class PreparedWrite:
    """A sync write checked and built ahead of sending (:meth:`DynamixelBus.prepare_sync_write`).
    ``dummies``: data for in-process dummy servos (``BusWithDummies``), written when it is sent."""

    address: int
    length: int
    ids: tuple[int, ...]
    packet: bytes
    dummies: Mapping[int, bytes] = dataclasses.field(default_factory=dict)


class Writes(Transport):
    """The group writes (a mixin of ``DynamixelBus``)."""

    def sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> bool:
        """Same item to many servos in one broadcast packet (no reply); True when sent."""
        return self.send_prepared(self.prepare_sync_write(address, length, data))

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> PreparedWrite:
        """Check and build a sync write now, to send it later with :meth:`send_prepared` (e.g.
        while a read is on the wire, so that the packet is ready the moment the line is free).
        ValueError for invalid IDs or data lengths, as :meth:`sync_write`."""
        data = {check_id(i): bytes(chunk) for i, chunk in data.items()}
        if not data:
            return PreparedWrite(address, length, (), b"")
        params = p.sync_write_params(address, length, data.items())
        return PreparedWrite(address, length, tuple(data),
                             p.build_instruction(p.BROADCAST_ID, p.SYNC_WRITE, params))

    def send_prepared(self, prepared: PreparedWrite) -> bool:
        """Send a write built by :meth:`prepare_sync_write`; True when sent (or nothing to send)."""
        if not prepared.packet:
            return True
        return self._broadcast_txn(prepared.packet, f"sync write @{prepared.address}x{prepared.length}")

    def bulk_write(self, data: Mapping[int, tuple[int, bytes]]) -> bool:
        """Different ``(address, bytes)`` per servo in one broadcast packet (no reply); True when sent."""
        data = {check_id(i): (int(a), bytes(chunk)) for i, (a, chunk) in data.items()}
        order = list(data)
        if not order:
            return True
        params = p.bulk_write_params((i, data[i][0], bytes(data[i][1])) for i in order)
        return self._broadcast_txn(p.build_instruction(p.BROADCAST_ID, p.BULK_WRITE, params),
                                   "bulk write")

    def _broadcast_txn(self, packet: bytes, what: str) -> bool:
        with self._transaction() as tx:
            sent = self._broadcast(packet)
            if sent:
                tx.ok(1, 1)
            else:
                tx.fail(f"{what}: {self._why(None)}")
            return sent

    def _broadcast(self, packet: bytes) -> bool:
        # no reply to gather: the input is flushed before the next packet that has one
        return self._send_or_lose(packet, flush=False)
