"""A group read on the wire (``GroupRead``), the bytes its replies take, and the checks of the
IDs every bus call is given."""
from __future__ import annotations

import operator
import time
from typing import Callable, Iterable

from ..protocol import host as p
from ..protocol.framers import PROTOCOL2, Framer
from .result import Failure


class GroupRead:
    """A sync read on the wire: ``result()`` waits for its replies (once; later calls return the
    same dict), ``failure`` (a ``Failure``) and ``why`` then say why when nobody answered (None
    and "" otherwise). ``eta`` is when
    they should be in (``time.monotonic()``). ``gather`` is called once by ``result()`` and must
    end with :meth:`finish`."""

    def __init__(self, gather: Callable[[GroupRead], None] | None, packet: bytes, expected: list[tuple[int, int]],
                 fast: bool, what: str) -> None:
        self._gather = gather
        self.packet = packet
        self.expected = expected
        self.fast = fast
        self.what = what
        self.sent = False
        self.reply_bytes = 0
        self.started = time.monotonic()
        self.eta = self.started
        self._data: dict[int, bytes] | None = None
        #: why the read failed (None while it has not, or when at least one servo answered)
        self.failure: Failure | None = None
        self.why = ""
        #: the status error byte of each servo that answered, where the protocol reports the
        #: servo's state in it (Protocol 1.0 reads); empty otherwise
        self.errors: dict[int, int] = {}
        #: the framing of its protocol
        self.framer: Framer = PROTOCOL2

    @classmethod
    def finished(cls, data: dict[int, bytes]) -> GroupRead:
        read = cls(None, b"", [], False, "")
        read._data = data
        return read

    @property
    def done(self) -> bool:
        return self._data is not None

    def finish(self, data: dict[int, bytes], failure: Failure | None = None, why: str = "") -> None:
        self._data = data
        self.failure = failure
        self.why = why

    def result(self) -> dict[int, bytes]:
        if self._data is None and self._gather is not None:
            self._gather(self)  # always ends with finish()
        return self._data if self._data is not None else {}


def reply_bytes(expected: list[tuple[int, int]], fast: bool, overhead: int = p.STATUS_OVERHEAD) -> int:
    """Bytes on the wire of the replies to a read of ``expected`` ``(id, size)``: one status packet
    each (``overhead``: a status's bytes without parameters), or one fast-read packet (header, ID,
    length, instruction, then ERR ID data CRC each)."""
    if fast:
        return 8 + sum(size + 4 for _, size in expected)
    return sum(overhead + size for _, size in expected)


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
