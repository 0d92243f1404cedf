"""``ServoBus``: what the handler needs of a bus. ``DynamixelBus`` (the serial bus) and
``dummy.BusWithDummies`` (the serial bus plus in-process dummy servos) both implement it (the tests'
fake bus is a ``DynamixelBus`` over a line in memory); which
IDs a bus serves in-process is not part of it (``dummy_ids``)."""
from __future__ import annotations

from typing import Any, Iterable, Mapping, Protocol, runtime_checkable

from .group_read import GroupRead
from .ops import Instruction
from .result import Result
from .stats import BusStats
from .writes import PreparedWrite


class StatsWire(Protocol):
    """What the loop statistics need of a bus: its counters, device and baud rate."""

    @property
    def stats(self) -> BusStats: ...
    @property
    def device(self) -> str: ...
    @property
    def baudrate(self) -> int: ...


@runtime_checkable
class ServoBus(StatsWire, Protocol):
    """One bus of servos as the handler uses it: one door for instructions (``execute`` takes a
    value of :mod:`.ops` and gives its ``Result``: the value, the ``Failure`` kind and why), and
    beside it the scan, the sync read left on the wire (a ``GroupRead``) and the sync write built
    ahead."""

    @property
    def latency_timer_ms(self) -> float: ...
    @property
    def is_open(self) -> bool: ...
    @property
    def inflight_eta(self) -> float | None: ...

    def open(self) -> None: ...
    def close(self) -> None: ...
    def reopen(self) -> None: ...
    def set_baudrate(self, baudrate: int) -> None: ...

    def execute(self, instruction: Instruction) -> Result[Any]: ...
    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]: ...
    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        *, protocol: int) -> GroupRead: ...
    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes],
                           *, protocol: int) -> PreparedWrite: ...


@runtime_checkable
class WithDummies(Protocol):
    """A bus that serves some IDs in-process (``dummy.BusWithDummies``)."""

    @property
    def dummies(self) -> Mapping[int, object]: ...


def dummy_ids(bus: object) -> list[int]:
    """The IDs ``bus`` serves in-process, in order (none for a plain serial bus)."""
    return sorted(bus.dummies) if isinstance(bus, WithDummies) else []
