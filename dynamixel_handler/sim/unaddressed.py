"""How long each servo went without an instruction while its bus watchdog was armed, from the
virtual bus's instruction log: what a servo's watchdog sees, so the trips it would record.

A servo's bus watchdog counts from the last instruction that reached it (any instruction naming
it: its own, a sync/bulk read or write that lists it, a broadcast ping); when the watchdog time
passes without one, the servo stops (a trip). ``unaddressed`` walks the log once, follows the
values the host wrote to Bus Watchdog (unicast or sync write) and measures every gap that starts
while a servo is armed. Used by the tests and benchmarks; the host side knows nothing of it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

from .. import protocol as p
from ..protocol.servo import LoggedInstruction

#: Bus Watchdog address and unit on X and P servos
BUS_WATCHDOG_ADDRESS = 98
BUS_WATCHDOG_MS = 20.0
#: instructions every servo on the bus hears, whatever their ID
_TO_ALL = (p.PING, p.ACTION, p.REBOOT, p.FACTORY_RESET, p.CLEAR)


@dataclass
class Unaddressed:
    """Per servo: the longest gap [s] that began while it was armed, and the gaps longer than the
    watchdog time then armed (the trips)."""

    longest_s: dict[int, float] = field(default_factory=dict)
    trips: dict[int, int] = field(default_factory=dict)

    @property
    def worst(self) -> tuple[int | None, float]:
        """(ID, seconds) of the longest armed gap of any servo."""
        if not self.longest_s:
            return None, 0.0
        dxl_id = max(self.longest_s, key=lambda i: self.longest_s[i])
        return dxl_id, self.longest_s[dxl_id]

    @property
    def trip_count(self) -> int:
        return sum(self.trips.values())


def _watchdog_writes(entry: LoggedInstruction) -> dict[int, int]:
    """{ID: value} of Bus Watchdog in a write instruction (signed byte), if it writes that item."""
    if entry.address is None or entry.length is None:
        return {}
    prm = entry.params
    if entry.instruction == p.WRITE and entry.address <= BUS_WATCHDOG_ADDRESS < entry.address + entry.length:
        return {entry.ids[0]: prm[2 + BUS_WATCHDOG_ADDRESS - entry.address]}
    if entry.instruction == p.SYNC_WRITE and entry.address <= BUS_WATCHDOG_ADDRESS < entry.address + entry.length:
        off, size = BUS_WATCHDOG_ADDRESS - entry.address, entry.length
        return {prm[k]: prm[k + 1 + off] for k in range(4, len(prm) - size, 1 + size)}
    return {}


def _reached(entry: LoggedInstruction, wanted: set[int]) -> set[int]:
    """Those of ``wanted`` the instruction reaches."""
    if p.BROADCAST_ID in entry.ids and entry.instruction in _TO_ALL:
        return wanted
    return wanted.intersection(entry.ids)


class _Walk:
    """The log walked once: when each servo was last reached, and its armed watchdog time."""

    def __init__(self, wanted: set[int], t0: float) -> None:
        self.wanted, self.t0 = wanted, t0
        self.armed: dict[int, float] = {}   # ID -> watchdog time [s] while armed
        self.last: dict[int, float] = {}    # ID -> time of the last instruction that reached it
        self.out = Unaddressed()

    def close(self, dxl_id: int, now: float) -> None:
        """The gap of ``dxl_id`` that ends at ``now``."""
        since, limit = self.last.get(dxl_id), self.armed.get(dxl_id)
        if since is None or limit is None or now < self.t0:
            return
        gap = now - since
        self.out.longest_s[dxl_id] = max(self.out.longest_s.get(dxl_id, 0.0), gap)
        if gap > limit:  # tripped: stays so until the host writes the watchdog again
            self.out.trips[dxl_id] = self.out.trips.get(dxl_id, 0) + 1
            self.armed.pop(dxl_id, None)

    def see(self, entry: LoggedInstruction) -> None:
        for dxl_id in _reached(entry, self.wanted):
            self.close(dxl_id, entry.time)
            self.last[dxl_id] = entry.time
        for dxl_id, value in _watchdog_writes(entry).items():
            self.armed.pop(dxl_id, None)
            if 1 <= value <= 127:
                self.armed[dxl_id] = value * BUS_WATCHDOG_MS / 1000.0


def unaddressed(log: Iterable[LoggedInstruction], ids: Iterable[int], t0: float = 0.0,
                t1: float | None = None) -> Unaddressed:
    """Armed gaps of the servos ``ids`` over the log entries (in time order); gaps are counted
    when they end in [t0, t1] (t1 None: the last entry; a gap still open then ends there)."""
    walk = _Walk(set(ids), t0)
    stop = t1
    for entry in log:
        if t1 is not None and entry.time > t1:
            break
        walk.see(entry)
        stop = entry.time if t1 is None else t1
    for dxl_id in walk.wanted:
        walk.close(dxl_id, stop if stop is not None else 0.0)
    return walk.out
