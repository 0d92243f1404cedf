"""Single-servo instructions of ``DynamixelBus``: read, write, registered write and action,
reboot, clear, factory reset. Each returns a ``Result``: what the servo gave, or why not."""
from __future__ import annotations

from ..protocol import host as p
from .group_read import check_id
from .result import Result
from .transport import Transport

_ACKNOWLEDGED: Result[bool] = Result(True)


class Instructions:
    """Instructions to one servo (or a broadcast one) over one ``Transport``."""

    def __init__(self, transport: Transport) -> None:
        self._t = transport

    def read(self, dxl_id: int, address: int, size: int) -> Result[bytes | None]:
        """``size`` raw bytes from the control table of ``dxl_id`` (None and why if not read)."""
        dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            status = t.unicast(dxl_id, p.READ, p.u16(address) + p.u16(size), size)
            if status is None or status.refused:
                return tx.failed(None, f"read ID {dxl_id} @{address}x{size}", status)
            tx.ok(1, 1)
            return Result(status.params)

    def send(self, instruction: int, what: str, dxl_id: int, params: bytes, retries: int | None = None) -> Result[bool]:
        """An instruction whose only answer is an acknowledgement: True when the servo acknowledged
        (broadcast: when sent). A unicast action's status reply is read and consumed here too.
        ``retries``: how often it is sent again without an answer (None: the bus's retry count)."""
        if dxl_id != p.BROADCAST_ID:
            dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            if dxl_id == p.BROADCAST_ID:
                if t.broadcast(p.build_instruction(dxl_id, instruction, params)):
                    tx.ok(1, 1)
                    return _ACKNOWLEDGED
                return tx.failed(False, f"{what} broadcast")
            status = t.unicast(dxl_id, instruction, params, 0, retries)
            if status is None or status.refused:
                return tx.failed(False, f"{what} ID {dxl_id}", status)
            tx.ok(1, 1)
            return _ACKNOWLEDGED

    def write(self, dxl_id: int, address: int, data: bytes) -> Result[bool]:
        return self.send(p.WRITE, "write", dxl_id, p.u16(address) + bytes(data))

    def reg_write(self, dxl_id: int, address: int, data: bytes) -> Result[bool]:
        return self.send(p.REG_WRITE, "reg_write", dxl_id, p.u16(address) + bytes(data))

    def action(self, dxl_id: int = p.BROADCAST_ID) -> Result[bool]:
        return self.send(p.ACTION, "action", dxl_id, b"")

    def reboot(self, dxl_id: int) -> Result[bool]:
        """Sent once: a servo whose acknowledgement came late has rebooted already, and a reboot
        sent again would reboot it a second time."""
        return self.send(p.REBOOT, "reboot", dxl_id, b"", retries=0)

    def clear_multi_turn(self, dxl_id: int) -> Result[bool]:
        return self.send(p.CLEAR, "clear multi-turn", dxl_id, b"\x01\x44\x58\x4c\x22")

    def clear_error(self, dxl_id: int, params: bytes) -> Result[bool]:
        """The error clear of a servo that has one (Y: Clear with P1 0x02 and its key)."""
        return self.send(p.CLEAR, "error clear", dxl_id, bytes(params))

    def factory_reset(self, dxl_id: int, option: int = 0x02) -> Result[bool]:
        if option not in (0x01, 0x02, 0xFF):
            raise ValueError(f"factory reset option must be 0x01, 0x02 or 0xFF, got {option:#x}")
        return self.send(p.FACTORY_RESET, "factory reset", dxl_id, bytes([option]))
