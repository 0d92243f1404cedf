"""Single-servo instructions of ``DynamixelBus``: read, write, registered write and action,
reboot, clear, factory reset, the error byte of a ping's status. Each instruction value frames
itself in the protocol its servo speaks (``ops``: ``frame(framer)``) and reads its answer from the
status, so one method sends them all. Each gives a ``Result``: what the servo gave, or why not,
and the error byte of the status that came back."""
from __future__ import annotations

from typing import Any

from ..protocol.framers import Framer
from .group_read import check_id
from .ops import ToOne
from .result import Failure, Result
from .transport import Transport


class Instructions:
    """Instructions to one servo (or a broadcast one) over one ``Transport``."""

    def __init__(self, transport: Transport) -> None:
        self._t = transport

    def execute(self, op: ToOne, framer: Framer) -> Result[Any]:
        """Send ``op`` in ``framer``'s protocol. A broadcast (where the instruction may be one) is
        done when sent; a unicast one when the servo answered, a unicast action's status included."""
        frame = op.frame(framer)
        if frame.instruction is None:
            return Result(op.FAILED, Failure.NOT_IN_PROTOCOL,
                          f"{frame.name} ID {op.dxl_id}: no such instruction in {framer.name}")
        t = self._t
        with t.transaction() as tx:
            if op.dxl_id == framer.broadcast_id:
                if t.broadcast(framer.instruction(op.dxl_id, frame.instruction, frame.params)):
                    tx.ok(1, 1)
                    return _ACKNOWLEDGED
                return tx.failed(op.FAILED, f"{frame.name} broadcast", None, framer=framer)
            dxl_id = check_id(op.dxl_id)
            status = t.unicast(dxl_id, frame.instruction, frame.params, frame.reply_params, frame.retries, framer=framer)
            if status is None or status.refused:
                return tx.failed(op.FAILED, f"{frame.name} ID {dxl_id}{frame.where}", status, framer=framer)
            tx.ok(1, 1)
            return Result(op.answer(status), error=status.error)


_ACKNOWLEDGED: Result[bool] = Result(True)
