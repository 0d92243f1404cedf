"""Single-servo instructions of ``DynamixelBus``: read, write, registered write and action,
reboot, clear, factory reset, each in the protocol its servo speaks (the ``framer``). Each returns
a ``Result``: what the servo gave, or why not."""
from __future__ import annotations

from ..protocol import host as p
from ..protocol.framers import PROTOCOL2, Framer
from .group_read import check_id
from .result import Failure, Result
from .transport import Transport

_ACKNOWLEDGED: Result[bool] = Result(True)


class Instructions:
    """Instructions to one servo (or a broadcast one) over one ``Transport``."""

    def __init__(self, transport: Transport) -> None:
        self._t = transport

    def read(self, dxl_id: int, address: int, size: int, framer: Framer = PROTOCOL2) -> Result[bytes | None]:
        """``size`` raw bytes from the control table of ``dxl_id`` (None and why if not read)."""
        dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            status = t.unicast(dxl_id, framer.READ, framer.read_params(address, size), size, framer=framer)
            if status is None or status.refused:
                return tx.failed(None, f"read ID {dxl_id} @{address}x{size}", status, framer)
            tx.ok(1, 1)
            return Result(status.params)

    def error_byte(self, dxl_id: int, framer: Framer) -> Result[int | None]:
        """The error byte of the status a ping gets (None and why without one)."""
        dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            status = t.unicast(dxl_id, framer.PING, b"", framer.ping_params(), None, framer)
            if status is None:
                return tx.failed(None, f"ping ID {dxl_id}", status, framer)
            tx.ok(1, 1)
            return Result(status.error)

    def send(self, instruction: int, what: str, dxl_id: int, params: bytes, retries: int | None = None,
             framer: Framer = PROTOCOL2) -> Result[bool]:
        """An instruction whose only answer is an acknowledgement: True when the servo acknowledged
        (broadcast: when sent). A unicast action's status reply is read and consumed here too.
        ``retries``: how often it is sent again without an answer (None: the bus's retry count)."""
        if dxl_id != framer.broadcast_id:
            dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            if dxl_id == framer.broadcast_id:
                if t.broadcast(framer.instruction(dxl_id, instruction, params)):
                    tx.ok(1, 1)
                    return _ACKNOWLEDGED
                return tx.failed(False, f"{what} broadcast", None, framer)
            status = t.unicast(dxl_id, instruction, params, 0, retries, framer)
            if status is None or status.refused:
                return tx.failed(False, f"{what} ID {dxl_id}", status, framer)
            tx.ok(1, 1)
            return _ACKNOWLEDGED

    def write(self, dxl_id: int, address: int, data: bytes, framer: Framer = PROTOCOL2) -> Result[bool]:
        return self.send(framer.WRITE, "write", dxl_id, framer.write_params(address, data), framer=framer)

    def reg_write(self, dxl_id: int, address: int, data: bytes, framer: Framer = PROTOCOL2) -> Result[bool]:
        return self.send(framer.REG_WRITE, "reg_write", dxl_id, framer.write_params(address, data), framer=framer)

    def action(self, dxl_id: int = p.BROADCAST_ID, framer: Framer = PROTOCOL2) -> Result[bool]:
        return self.send(framer.ACTION, "action", dxl_id, b"", framer=framer)

    def reboot(self, dxl_id: int, framer: Framer = PROTOCOL2) -> Result[bool]:
        """Sent once: a servo whose acknowledgement came late has rebooted already, and a reboot
        sent again would reboot it a second time."""
        return self.send(framer.REBOOT, "reboot", dxl_id, b"", retries=0, framer=framer)

    def clear_multi_turn(self, dxl_id: int, framer: Framer = PROTOCOL2) -> Result[bool]:
        if framer.CLEAR is None:
            return _not_in(framer, "clear multi-turn", dxl_id)
        return self.send(framer.CLEAR, "clear multi-turn", dxl_id, b"\x01\x44\x58\x4c\x22", framer=framer)

    def clear_error(self, dxl_id: int, params: bytes, framer: Framer = PROTOCOL2) -> Result[bool]:
        """The error clear of a servo that has one (Y: Clear with P1 0x02 and its key)."""
        if framer.CLEAR is None:
            return _not_in(framer, "error clear", dxl_id)
        return self.send(framer.CLEAR, "error clear", dxl_id, bytes(params), framer=framer)

    def factory_reset(self, dxl_id: int, option: int = 0x02, framer: Framer = PROTOCOL2) -> Result[bool]:
        """Protocol 2.0: ``option`` says what is kept; Protocol 1.0's reset has no option (it resets all)."""
        return self.send(framer.FACTORY_RESET, "factory reset", dxl_id, framer.factory_reset_params(option),
                         framer=framer)


def _not_in(framer: Framer, what: str, dxl_id: int) -> Result[bool]:
    return Result(False, Failure.NOT_IN_PROTOCOL, f"{what} ID {dxl_id}: no such instruction in {framer.name}")
