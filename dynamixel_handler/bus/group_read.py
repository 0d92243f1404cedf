"""A group read on the wire (``GroupRead``), the bytes its replies take, and the checks of the
IDs every bus call is given."""
from __future__ import annotations

import operator
import time
from typing import TYPE_CHECKING, Iterable

from ..protocol import host as p

if TYPE_CHECKING:
    from .transport import Transport


class GroupRead:
    """A sync read on the wire: ``result()`` waits for its replies (once; later calls return the
    same dict). ``eta`` is when they should be in (``time.monotonic()``)."""

    def __init__(self, bus: Transport | None, packet: bytes, expected: list[tuple[int, int]], fast: bool,
                 what: str) -> None:
        self._bus = bus
        self.packet = packet
        self.expected = expected
        self.fast = fast
        self.what = what
        self.sent = False
        self.reply_bytes = 0
        self.started = time.monotonic()
        self.eta = self.started
        self._data: dict[int, bytes] | None = None

    @classmethod
    def finished(cls, data: dict[int, bytes]) -> GroupRead:
        read = cls(None, b"", [], False, "")
        read._data = data
        return read

    @property
    def done(self) -> bool:
        return self._data is not None

    def finish(self, data: dict[int, bytes]) -> None:
        self._data = data

    def result(self) -> dict[int, bytes]:
        if self._data is None and self._bus is not None:
            self._bus._finish_group_read(self)  # always ends with finish()
        return self._data if self._data is not None else {}


def reply_bytes(expected: list[tuple[int, int]], fast: bool) -> int:
    """Bytes on the wire of the replies to a read of ``expected`` ``(id, size)``: one status packet
    each, or one fast-read packet (header, ID, length, instruction, then ERR ID data CRC each)."""
    if fast:
        return 8 + sum(size + 4 for _, size in expected)
    return sum(p.STATUS_OVERHEAD + size for _, size in expected)


def check_id(dxl_id: int) -> int:
    """The ID as a plain int (numpy integers welcome); ValueError outside 0..252."""
    try:
        value = operator.index(dxl_id)
    except TypeError:
        value = -1
    if not 0 <= value <= p.MAX_ID:
        raise ValueError(f"invalid Dynamixel ID {dxl_id!r}: servo IDs are 0..252")
    return value


def unique_ids(ids: Iterable[int]) -> list[int]:
    order: list[int] = []
    for dxl_id in ids:
        value = check_id(dxl_id)
        if value not in order:
            order.append(value)
    return order
