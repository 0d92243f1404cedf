"""The instructions a bus executes, as values: ``bus.execute(Read(1, 132, 4))`` gives a
``Result`` (the data, or None and why). Each value is checked when it is made (an ID out of
range raises ValueError there, not on the wire), can be logged, compared and kept, and says by
its type what its result holds:

- ``Ping`` -> the model number (int) or None; ``ErrorByte`` -> a ping's status error byte or None
- ``Read`` -> the bytes read or None
- ``Write``, ``RegWrite``, ``Action``, ``Reboot``, ``ClearMultiTurn``, ``ClearError``,
  ``FactoryReset``, ``BulkWrite`` and a ``PreparedWrite`` (a sync write built ahead) -> True when
  acknowledged (a broadcast: when sent), else False
- ``SyncRead``, ``BulkRead`` -> ``{id: bytes}`` of the servos that answered ({} and why when none)

``protocol`` says which framing the servo speaks (2: Protocol 2.0; 1: Protocol 1.0).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Union

from ..protocol import BROADCAST_ID
from .group_read import check_id, unique_ids
from .writes import PreparedWrite


def _target(dxl_id: int) -> int:
    """A servo ID, or the broadcast ID where an instruction may be broadcast."""
    return BROADCAST_ID if dxl_id == BROADCAST_ID else check_id(dxl_id)


@dataclass(frozen=True, slots=True)
class Ping:
    dxl_id: int
    #: how often it is sent again without an answer (None: the bus's retry count)
    retries: int | None = None
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))


@dataclass(frozen=True, slots=True)
class ErrorByte:
    """The error byte of the servo's status to a ping: its state where the protocol reports it
    there (Protocol 1.0: input voltage, overheating, overload ...). Result: the byte, or None."""

    dxl_id: int
    protocol: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))


@dataclass(frozen=True, slots=True)
class Read:
    dxl_id: int
    address: int
    size: int
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", check_id(self.dxl_id))


@dataclass(frozen=True, slots=True)
class Write:
    dxl_id: int
    address: int
    data: bytes
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "data", bytes(self.data))


@dataclass(frozen=True, slots=True)
class RegWrite:
    """A write the servo holds until an ``Action``."""

    dxl_id: int
    address: int
    data: bytes
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "data", bytes(self.data))


@dataclass(frozen=True, slots=True)
class Action:
    """Execute registered writes (a unicast action's status is read and consumed)."""

    dxl_id: int = BROADCAST_ID
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))


@dataclass(frozen=True, slots=True)
class Reboot:
    """Sent once whatever the retry count: a servo whose acknowledgement came late has rebooted
    already, and a reboot sent again would reboot it a second time."""

    dxl_id: int
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))


@dataclass(frozen=True, slots=True)
class ClearMultiTurn:
    """Reset the present position to within one turn (Clear instruction; the servo must be stopped)."""

    dxl_id: int
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))


@dataclass(frozen=True, slots=True)
class ClearError:
    """The Clear instruction with a family's error-clear parameters (Y: P1 0x02 and its key)."""

    dxl_id: int
    params: bytes
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        object.__setattr__(self, "params", bytes(self.params))


@dataclass(frozen=True, slots=True)
class FactoryReset:
    """Option 0xFF resets all, 0x01 all but the ID, 0x02 (default) all but ID and baud rate."""

    dxl_id: int
    option: int = 0x02
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "dxl_id", _target(self.dxl_id))
        if self.option not in (0x01, 0x02, 0xFF):
            raise ValueError(f"factory reset option must be 0x01, 0x02 or 0xFF, got {self.option:#x}")


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
    protocol: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "ids", tuple(unique_ids(self.ids)))


@dataclass(frozen=True, slots=True)
class BulkRead:
    """A different ``(address, size)`` per servo in one instruction: ``{id: (address, size)}``."""

    requests: Mapping[int, tuple[int, int]]
    fast: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "requests", {check_id(i): (int(a), int(n)) for i, (a, n) in self.requests.items()})


@dataclass(frozen=True, slots=True)
class BulkWrite:
    """A different ``(address, bytes)`` per servo in one broadcast packet: ``{id: (address, data)}``."""

    data: Mapping[int, tuple[int, bytes]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", {check_id(i): (int(a), bytes(d)) for i, (a, d) in self.data.items()})


#: what ``execute`` takes
Instruction = Union[Ping, ErrorByte, Read, Write, RegWrite, Action, Reboot, ClearMultiTurn, ClearError, FactoryReset,
                    SyncRead, BulkRead, BulkWrite, PreparedWrite]

__all__ = ["Action", "BulkRead", "BulkWrite", "ClearError", "ClearMultiTurn", "ErrorByte", "FactoryReset", "Instruction",
           "Ping", "PreparedWrite", "Read", "Reboot", "RegWrite", "SyncRead", "Write"]
