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

``DynamixelBus`` is composed of ``transport.Transport`` (the line, transactions, retries, the read
in flight), ``reads.Reads`` (group reads, scan), ``writes.Writes`` (group writes) and the
single-servo instructions below. Only ``DynamixelBus`` methods are meant for callers; it is
ROS-free.
"""
from __future__ import annotations

from typing import Mapping

from ..protocol import host as p
from .group_read import check_id
from .reads import Reads
from .writes import Writes


class DynamixelBus(Reads, Writes):
    """One Protocol 2.0 serial bus (see ``Transport`` for failures and retries)."""

    @property
    def dummies(self) -> Mapping[int, object]:
        """In-process dummy servos on this bus: none (``BusWithDummies`` has them)."""
        return {}

    def read(self, dxl_id: int, address: int, size: int) -> bytes | None:
        """``size`` raw bytes from the control table of ``dxl_id``, or None."""
        dxl_id = check_id(dxl_id)
        with self._transaction() as tx:
            status = self._unicast(dxl_id, p.READ, p.u16(address) + p.u16(size), size)
            if status is None or status.refused:
                tx.fail(f"read ID {dxl_id} @{address}x{size}: {self._why(status)}")
                return None
            tx.ok(1, 1)
            return status.params

    def write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Write raw bytes; True when the servo acknowledged (broadcast: when sent)."""
        return self._write_like(p.WRITE, "write", dxl_id, p.u16(address) + bytes(data))

    def reg_write(self, dxl_id: int, address: int, data: bytes) -> bool:
        """Register a write to be executed by :meth:`action`."""
        return self._write_like(p.REG_WRITE, "reg_write", dxl_id, p.u16(address) + bytes(data))

    def action(self, dxl_id: int = p.BROADCAST_ID) -> bool:
        """Execute registered writes. A unicast action's status reply is read and consumed here."""
        return self._write_like(p.ACTION, "action", dxl_id, b"")

    def reboot(self, dxl_id: int) -> bool:
        """Reboot a servo (it needs a few hundred ms before it answers again)."""
        return self._write_like(p.REBOOT, "reboot", dxl_id, b"")

    def clear_multi_turn(self, dxl_id: int) -> bool:
        """Reset the present position to within one turn (Clear instruction, servo must be stopped)."""
        return self._write_like(p.CLEAR, "clear multi-turn", dxl_id, b"\x01\x44\x58\x4c\x22")

    def factory_reset(self, dxl_id: int, option: int = 0x02) -> bool:
        """Factory reset; option 0xFF all, 0x01 all but ID, 0x02 (default) all but ID and baud rate."""
        if option not in (0x01, 0x02, 0xFF):
            raise ValueError(f"factory reset option must be 0x01, 0x02 or 0xFF, got {option:#x}")
        return self._write_like(p.FACTORY_RESET, "factory reset", dxl_id, bytes([option]))

    def _write_like(self, instruction: int, what: str, dxl_id: int, params: bytes) -> bool:
        if dxl_id != p.BROADCAST_ID:
            dxl_id = check_id(dxl_id)
        with self._transaction() as tx:
            if dxl_id == p.BROADCAST_ID:
                sent = self._broadcast(p.build_instruction(dxl_id, instruction, params))
                if sent:
                    tx.ok(1, 1)
                else:
                    tx.fail(f"{what} broadcast: {self._why(None)}")
                return sent
            status = self._unicast(dxl_id, instruction, params, 0)
            if status is None or status.refused:
                tx.fail(f"{what} ID {dxl_id}: {self._why(status)}")
                return False
            tx.ok(1, 1)
            return True
