"""The one search every verb uses to find its servos: at the ``--baud`` rate when it is given, else
at every rate (the bus's first, then where unboxed and set-up servos usually are). A list of IDs
comes back as the servos found (each with its rate) and the IDs that answer nowhere, so a verb can
do its work on the ones there and name each missing one; no list means every servo on the bus."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ..bus import BusError, DynamixelBus
from ..bus.ops import Ping
from ..control_table import model_by_number
from .errors import StepFailed
from .protocol1 import model_name1, ping1
from .servo import SEARCH_ORDER, Servo

__all__ = ["Placed", "Search", "Found"]

#: from this many IDs on, one broadcast ping per rate finds them (else one ping each)
_BROADCAST_FROM = 5


@dataclass
class Placed:
    """A servo and the baud rate it answers at."""

    servo: Servo
    baudrate: int

    @property
    def dxl_id(self) -> int:
        return self.servo.dxl_id


@dataclass
class Found:
    """What a search found: the servos (in ID order) and the IDs asked for that answer nowhere."""

    placed: list[Placed] = field(default_factory=list)
    missing: list[int] = field(default_factory=list)
    #: the rates looked at (for the message about a missing ID)
    rates: list[int] = field(default_factory=list)

    def why_missing(self, dxl_id: int) -> str:
        where = f"{self.rates[0]} bps" if len(self.rates) == 1 else \
            f"any baud rate ({', '.join(map(str, self.rates))} bps)"
        return f"ID {dxl_id}: no servo answers at {where}"


def _servo(bus: DynamixelBus, dxl_id: int, number: int) -> Servo:
    """The servo whose ping gave model ``number``; StepFailed when the control table lacks it."""
    try:
        return Servo(bus, dxl_id, model_by_number(number))
    except KeyError:
        raise StepFailed(f"ID {dxl_id}: model number {number} is not in the control table; "
                         "the tool only sets up models the handler knows") from None


class Search:
    """Finding servos on ``bus``: at its rate only when ``baud_given``, else at every rate."""

    def __init__(self, bus: DynamixelBus, baud_given: bool) -> None:
        self.bus = bus
        self.baud_given = baud_given
        #: the rate the bus was opened at (``--baud``, or 57600): looked at first
        self.first = bus.baudrate

    def rates(self) -> list[int]:
        if self.baud_given:
            return [self.first]
        return [self.first] + [bps for bps in SEARCH_ORDER if bps != self.first]

    def _at(self, bps: int) -> bool:
        try:
            self.bus.set_baudrate(bps)
        except BusError:  # the adapter cannot use this rate: no servo can be reached there
            return False
        return True

    def _answering(self, ids: Sequence[int]) -> dict[int, int]:
        if len(ids) >= _BROADCAST_FROM:
            return self.bus.scan(ids, broadcast=True)
        answered = {}
        for dxl_id in ids:
            model = self.bus.execute(Ping(dxl_id)).value  # retried as --retries says
            if model is not None:
                answered[dxl_id] = model
        return answered

    def _where(self, wanted: list[int], every: bool, rates: list[int]) -> dict[int, tuple[int, int]]:
        """ID -> (the rate it answers at, its model number); every rate is looked at when ``every``
        (else only until each wanted ID answered)."""
        where: dict[int, tuple[int, int]] = {}
        for bps in rates:
            rest = wanted if every else [i for i in wanted if i not in where]
            if not rest or not self._at(bps):
                continue
            for dxl_id, number in self._answering(rest).items():
                if dxl_id in where:
                    raise StepFailed(f"ID {dxl_id} answers at {where[dxl_id][0]} and at {bps} bps: two servos share "
                                     "it; give --baud to choose one, or give one of them another ID")
                where[dxl_id] = (bps, number)
        return where

    def find(self, ids: Sequence[int] | None) -> Found:
        """The servos at ``ids`` (None: every servo at every rate looked at). An ID that answers at
        two rates is refused with both named (two servos share it: which one is meant?)."""
        wanted = list(range(253)) if ids is None else sorted(set(ids))
        result = Found(rates=self.rates())
        where = self._where(wanted, ids is None, result.rates)
        for dxl_id, (bps, number) in sorted(where.items()):
            result.placed.append(Placed(_servo(self.bus, dxl_id, number), bps))
        result.missing = [i for i in wanted if i not in where] if ids is not None else []
        self._at(result.placed[0].baudrate if result.placed else self.first)
        return result

    def again(self, ids: Sequence[int], rates: Sequence[int]) -> list[Placed]:
        """Those of ``ids`` that answer now at one of ``rates`` (a quick look for servos plugged in
        since; one ping per ID and rate), the bus left at the rate it was at. A model the control
        table lacks is left out."""
        before = self.bus.baudrate
        try:
            where = self._where(sorted(set(ids)), False, list(rates))
        finally:
            self._at(before)
        placed = []
        for dxl_id, (bps, number) in sorted(where.items()):
            try:
                placed.append(Placed(_servo(self.bus, dxl_id, number), bps))
            except StepFailed:
                continue
        return placed

    def everywhere(self) -> list[tuple[int, int, int]]:
        """(ID, rate, model number) of every servo answering at every rate looked at, one ID at
        two rates listed twice (restore looks there for a replacement); the bus at the first rate."""
        seen = []
        for bps in self.rates():
            if self._at(bps):
                seen += [(dxl_id, bps, number) for dxl_id, number in self.bus.scan(range(253), broadcast=True).items()]
        self._at(self.first)
        return seen

    def one(self, dxl_id: int) -> Servo:
        """The servo at ``dxl_id``, the bus left at its rate; StepFailed when it answers nowhere."""
        found = self.find([dxl_id])
        if not found.placed:
            raise StepFailed(found.why_missing(dxl_id) + self._protocol1(dxl_id, found.rates))
        self._at(found.placed[0].baudrate)
        return found.placed[0].servo

    def _protocol1(self, dxl_id: int, rates: Sequence[int]) -> str:
        """What to add when ``dxl_id`` answers Protocol 1.0 at one of ``rates`` ("" when it does not)."""
        for bps in rates:
            got = ping1(self.bus, dxl_id) if self._at(bps) else None
            if got is not None:
                self._at(self.first)
                try:
                    name = model_by_number(got[0]).name + " set to Protocol Type 1"
                except KeyError:
                    name = model_name1(got[0])
                return (f"; it answers Protocol 1.0 at {bps} bps ({name}): this tool cannot read or write it yet "
                        "(scan says how to bring it to Protocol 2.0)")
        self._at(self.first)
        return ""

    def every(self) -> Found:
        """Every servo on the bus; StepFailed when none answers."""
        found = self.find(None)
        if not found.placed:
            rates = found.rates
            where = f"{rates[0]} bps" if len(rates) == 1 else "any baud rate"
            raise StepFailed(f"no servo answers at {where} on {self.bus.device}")
        return found
