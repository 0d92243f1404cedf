"""Group writes of ``DynamixelBus``: sync write (also built ahead and sent later) and bulk write;
broadcast packets, no reply: a write fails only when it cannot be sent."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping

from ..protocol import host as p
from ..protocol.framers import FRAMERS
from .group_read import check_id
from .result import Result
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


class Writes:
    """The group writes over one ``Transport``."""

    def __init__(self, transport: Transport) -> None:
        self._t = transport

    @staticmethod
    def prepare_sync_write(address: int, length: int, data: Mapping[int, bytes], *, protocol: int) -> PreparedWrite:
        """Check and build a sync write in ``protocol`` now, to send it later with
        :meth:`send_prepared` (e.g. while a read is on the wire, so that the packet is ready the
        moment the line is free). ValueError for invalid IDs or data lengths."""
        data = {check_id(i): bytes(chunk) for i, chunk in data.items()}
        if not data:
            return PreparedWrite(address, length, (), b"")
        framer = FRAMERS[protocol]
        params = framer.sync_write_params(address, length, data.items())
        return PreparedWrite(address, length, tuple(data),
                             framer.instruction(framer.broadcast_id, framer.SYNC_WRITE, params))

    def send_prepared(self, prepared: PreparedWrite) -> Result[bool]:
        """Send a write built by :meth:`prepare_sync_write`: True when sent (or nothing to send)."""
        if not prepared.packet:
            return _SENT
        return self.send(prepared.packet, f"sync write @{prepared.address}x{prepared.length}")

    def bulk_write(self, data: Mapping[int, tuple[int, bytes]]) -> Result[bool]:
        """Different ``(address, bytes)`` per servo in one broadcast packet: True when sent."""
        data = {check_id(i): (int(a), bytes(chunk)) for i, (a, chunk) in data.items()}
        order = list(data)
        if not order:
            return _SENT
        params = p.bulk_write_params((i, data[i][0], bytes(data[i][1])) for i in order)
        return self.send(p.build_instruction(p.BROADCAST_ID, p.BULK_WRITE, params), "bulk write")

    def send(self, packet: bytes, what: str) -> Result[bool]:
        """One broadcast packet as a transaction of its own."""
        t = self._t
        with t.transaction() as tx:
            if t.broadcast(packet):
                tx.ok(1, 1)
                return _SENT
            return tx.failed(False, f"{what}")


_SENT: Result[bool] = Result(True)
