"""The instructions a bus executes, as values: ``bus.execute(Read(1, 132, 4, protocol=2))`` gives a
``Result`` (the data, or None and why). Each value is checked when it is made (an ID out of
range raises ValueError there, not on the wire), can be logged, compared and kept, and says by
its type what its result holds:

- ``Ping`` -> the model number (int) or None; ``ErrorByte`` -> a ping's status error byte or None
- ``Read`` -> the bytes read or None
- ``Write``, ``RegWrite``, ``Action``, ``Reboot``, ``ClearMultiTurn``, ``ClearError``,
  ``FactoryReset``, ``BulkWrite`` and a ``PreparedWrite`` (a sync write built ahead) -> True when
  acknowledged (a broadcast: when sent), else False
- ``SyncRead``, ``BulkRead`` -> ``{id: bytes}`` of the servos that answered ({} and why when none)

``protocol`` says which framing the servo speaks (2: Protocol 2.0; 1: Protocol 1.0): a keyword every
instruction must be given (``Read(1, 132, 4, protocol=2)``), never a default a Protocol 1.0 servo
would be sent in the wrong framing by.

An instruction to one servo frames itself (``frame(framer)``: the instruction code, its parameters,
the reply it waits for, how often it is sent again, its name in a log line) and reads its answer
from the status (``answer``), so the bus sends every such instruction the same way
(``Instructions.execute``) on any line.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Union

from ..protocol import BROADCAST_ID
from ..protocol.framers import Framer
from .group_read import check_id, unique_ids
from .writes import PreparedWrite


@dataclass(frozen=True, slots=True)
class Frame:
    """How an instruction to one servo goes on the wire in one protocol."""

    #: the instruction's name in a log line ("read": "read ID 3 @132x4")
    name: str
    #: the instruction code; None: the protocol has no such instruction (a Clear in Protocol 1.0)
    instruction: int | None
    params: bytes = b""
    #: parameter bytes of the reply (0: an acknowledgement)
    reply_params: int = 0
    #: how often it is sent again without an answer (None: the bus's retry count)
    retries: int | None = None
    #: what a log line adds after the ID (" @132x4")
    where: str = ""


class _Acknowledged:
    """An instruction whose answer is an acknowledgement: True, False when not acknowledged."""

    __slots__ = ()
    FAILED: Any = False

    @staticmethod
    def answer(status: Any) -> Any:
        return True


def _target(dxl_id: int) -> int:
    """A servo ID, or the broadcast ID where an instruction may be broadcast."""
    return BROADCAST_ID if dxl_id == BROADCAST_ID else check_id(dxl_id)


@dataclass(frozen=True, slots=True)
class Ping:
    dxl_id: int
    #: how often it is sent again without an answer (None: the bus's retry count)
    retries: int | None = None
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))


@dataclass(frozen=True, slots=True)
class ErrorByte:
    """The error byte of the servo's status to a ping: its state where the protocol reports it
    there (Protocol 1.0: input voltage, overheating, overload ...). Result: the byte, or None."""

    dxl_id: int
    protocol: int = field(kw_only=True)
    FAILED = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))

    def frame(self, framer: Framer) -> Frame:
        return Frame("ping", framer.PING, b"", framer.ping_params())

    @staticmethod
    def answer(status: Any) -> Any:
        return status.error


@dataclass(frozen=True, slots=True)
class Read:
    dxl_id: int
    address: int
    size: int
    protocol: int = field(kw_only=True)
    FAILED = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))

    def frame(self, framer: Framer) -> Frame:
        return Frame("read", framer.READ, framer.read_params(self.address, self.size), self.size,
                     where=f" @{self.address}x{self.size}")

    @staticmethod
    def answer(status: Any) -> Any:
        return status.params


@dataclass(frozen=True, slots=True)
class Write(_Acknowledged):
    dxl_id: int
    address: int
    data: bytes
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "data", bytes(self.data))

    def frame(self, framer: Framer) -> Frame:
        return Frame("write", framer.WRITE, framer.write_params(self.address, self.data))


@dataclass(frozen=True, slots=True)
class RegWrite(_Acknowledged):
    """A write the servo holds until an ``Action``."""

    dxl_id: int
    address: int
    data: bytes
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "data", bytes(self.data))

    def frame(self, framer: Framer) -> Frame:
        return Frame("reg_write", framer.REG_WRITE, framer.write_params(self.address, self.data))


@dataclass(frozen=True, slots=True)
class Action(_Acknowledged):
    """Execute registered writes (a unicast action's status is read and consumed)."""

    dxl_id: int = BROADCAST_ID
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))

    def frame(self, framer: Framer) -> Frame:
        return Frame("action", framer.ACTION)


@dataclass(frozen=True, slots=True)
class Reboot(_Acknowledged):
    """Sent once whatever the retry count: a servo whose acknowledgement came late has rebooted
    already, and a reboot sent again would reboot it a second time."""

    dxl_id: int
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))

    def frame(self, framer: Framer) -> Frame:
        return Frame("reboot", framer.REBOOT, retries=0)


@dataclass(frozen=True, slots=True)
class ClearMultiTurn(_Acknowledged):
    """Reset the present position to within one turn (Clear instruction; the servo must be stopped)."""

    dxl_id: int
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))

    def frame(self, framer: Framer) -> Frame:
        return Frame("clear multi-turn", framer.CLEAR, _MULTI_TURN_KEY)


@dataclass(frozen=True, slots=True)
class ClearError(_Acknowledged):
    """The Clear instruction with a family's error-clear parameters (Y: P1 0x02 and its key)."""

    dxl_id: int
    params: bytes
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "params", bytes(self.params))

    def frame(self, framer: Framer) -> Frame:
        return Frame("error clear", framer.CLEAR, self.params)


@dataclass(frozen=True, slots=True)
class FactoryReset(_Acknowledged):
    """Option 0xFF resets all, 0x01 all but the ID, 0x02 (default) all but ID and baud rate.
    Protocol 1.0's reset has no option (it resets all)."""

    dxl_id: int
    option: int = 0x02
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        if self.option not in (0x01, 0x02, 0xFF):
            raise ValueError(f"factory reset option must be 0x01, 0x02 or 0xFF, got {self.option:#x}")

    def frame(self, framer: Framer) -> Frame:
        return Frame("factory reset", framer.FACTORY_RESET, framer.factory_reset_params(self.option))


@dataclass(frozen=True, slots=True)
class SyncRead:
    """The same item from many servos in one instruction; ``fast``: Fast Sync Read (X firmware
    45+, P 12+), one reply for all. A silent servo costs one reply wait and never empties the
    others' data; the instruction is sent again only when nobody answered."""

    address: int
    length: int
    ids: tuple[int, ...]
    fast: bool = False
    #: 1: Protocol 1.0 servos, which have no Sync Read: each is read on its own
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "ids", tuple(unique_ids(self.ids)))


@dataclass(frozen=True, slots=True)
class BulkRead:
    """A different ``(address, size)`` per servo in one instruction: ``{id: (address, size)}``."""

    requests: Mapping[int, tuple[int, int]]
    fast: bool = False
    #: 1: Protocol 1.0 servos (MX, EX): each answers with a status of its own
    protocol: int = field(kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "requests", {check_id(i): (int(a), int(n)) for i, (a, n) in self.requests.items()})


@dataclass(frozen=True, slots=True)
class BulkWrite:
    """A different ``(address, bytes)`` per servo in one broadcast packet: ``{id: (address, data)}``."""

    data: Mapping[int, tuple[int, bytes]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", {check_id(i): (int(a), bytes(d)) for i, (a, d) in self.data.items()})


#: the Clear instruction's key for a multi-turn reset (P1 0x01, then "DXL" and 0x22)
_MULTI_TURN_KEY = b"\x01\x44\x58\x4c\x22"

#: an instruction to one servo (or a broadcast one) that frames itself
ToOne = Union[ErrorByte, Read, Write, RegWrite, Action, Reboot, ClearMultiTurn, ClearError, FactoryReset]

#: what ``execute`` takes
Instruction = Union[Ping, ErrorByte, Read, Write, RegWrite, Action, Reboot, ClearMultiTurn, ClearError, FactoryReset,
                    SyncRead, BulkRead, BulkWrite, PreparedWrite]

__all__ = ["Action", "BulkRead", "BulkWrite", "ClearError", "ClearMultiTurn", "ErrorByte", "FactoryReset", "Frame",
           "Instruction", "Ping", "PreparedWrite", "Read", "Reboot", "RegWrite", "SyncRead", "ToOne", "Write"]
