"""The one search every verb uses to find its servos: at the ``--baud`` rate when one is given, at the
rates of a ``--baud`` list in its order, else at every rate (the bus's first, then where unboxed and
set-up servos usually are). A list of IDs
comes back as the servos found (each with its rate) and the IDs that answer nowhere, so a verb can
do its work on the ones there and name each missing one; no list means every servo on the bus.

Both protocols: an ID asked for is pinged in Protocol 2.0 and, where none answers, in Protocol 1.0
(at the rates a Protocol 1.0 servo can be at); the search for every servo looks in Protocol 2.0 (one
broadcast ping per rate) and in Protocol 1.0 only when ``--protocol 1`` or ``both`` asks for it (a
Protocol 1.0 servo has no broadcast ping: each of the 253 IDs is pinged, about 3 s a rate)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Collection, Sequence

from ..bus import BusError, DynamixelBus
from ..bus.ops import Ping
from .errors import StepFailed
from .per_protocol import tool_protocol
from .protocol1 import ping1, rates1
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


def _servo(bus: DynamixelBus, dxl_id: int, number: int, protocol: int = 2) -> Servo:
    """The servo whose ping in ``protocol`` gave model ``number``; StepFailed when the control table
    lacks it."""
    try:
        return Servo(bus, dxl_id, tool_protocol(protocol).model_for(number), protocol)
    except KeyError:
        raise StepFailed(f"ID {dxl_id}: model number {number} (Protocol {protocol}.0) is not in the control table; "
                         "the tool only sets up models the handler knows") from None


#: ID -> (rate, model number, protocol)
Where = dict[int, tuple[int, int, int]]


class Search:
    """Finding servos on ``bus``: at its rate only when ``baud_given``, else at the rates of
    ``listed`` (a ``--baud`` list; empty: every rate); ``protocols``: where the search for every
    servo looks ("2", "1", "both"; None: Protocol 2.0)."""

    def __init__(self, bus: DynamixelBus, baud_given: bool, protocols: str | None = None,
                 listed: Sequence[int] = ()) -> None:
        self.bus = bus
        self.baud_given = baud_given
        self.listed = list(listed)
        #: the rate the bus was opened at (``--baud``, or 57600): looked at first
        self.first = bus.baudrate
        #: the protocols an ID asked for is pinged in, and those the search for every servo uses
        self.for_ids = {"2": (2,), "1": (1,)}.get(protocols or "", (2, 1))
        self.for_all = {"1": (1,), "both": (2, 1)}.get(protocols or "", (2,))

    def rates(self) -> list[int]:
        if self.baud_given:
            return [self.first]
        return [self.first] + [bps for bps in (self.listed or SEARCH_ORDER) if bps != self.first]

    def _at(self, bps: int) -> bool:
        try:
            self.bus.set_baudrate(bps)
        except BusError:  # the adapter cannot use this rate: no servo can be reached there
            return False
        return True

    def _answering(self, ids: Sequence[int], protocols: Sequence[int]) -> dict[int, tuple[int, int]]:
        """ID -> (model number, protocol) of those of ``ids`` that answer at the bus's rate."""
        answered = {i: (n, 2) for i, n in self._answering2(ids).items()} if 2 in protocols else {}
        if 1 in protocols and self.bus.baudrate in rates1():
            for dxl_id in (i for i in ids if i not in answered):
                got = ping1(self.bus, dxl_id, retries=0 if len(ids) >= _BROADCAST_FROM else 1)
                if got is not None:
                    answered[dxl_id] = (got, 1)
        return answered

    def _answering2(self, ids: Sequence[int]) -> dict[int, int]:
        if len(ids) >= _BROADCAST_FROM:
            return self.bus.scan(ids, broadcast=True)
        answered = {}
        for dxl_id in ids:
            model = self.bus.execute(Ping(dxl_id, protocol=2)).value  # retried as --retries says
            if model is not None:
                answered[dxl_id] = model
        return answered

    def _where(self, wanted: list[int], every: bool, rates: list[int], protocols: Sequence[int] = (2, 1)) -> Where:
        """ID -> (the rate it answers at, its model number, protocol); every rate is looked at when
        ``every`` (else only until each wanted ID answered)."""
        where: Where = {}
        for bps in rates:
            rest = wanted if every else [i for i in wanted if i not in where]
            if not rest or not self._at(bps):
                continue
            for dxl_id, (number, protocol) in self._answering(rest, protocols).items():
                if dxl_id in where:
                    raise StepFailed(f"ID {dxl_id} answers at {where[dxl_id][0]} and at {bps} bps: two servos share "
                                     "it; give --baud to choose one, or give one of them another ID")
                where[dxl_id] = (bps, number, protocol)
        return where

    def find(self, ids: Sequence[int] | None) -> Found:
        """The servos at ``ids`` (None: every servo at every rate looked at). An ID that answers at
        two rates is refused with both named (two servos share it: which one is meant?)."""
        wanted = list(range(253)) if ids is None else sorted(set(ids))
        result = Found(rates=self.rates())
        where = self._where(wanted, ids is None, result.rates, self.for_all if ids is None else self.for_ids)
        for dxl_id, (bps, number, protocol) in sorted(where.items()):
            result.placed.append(Placed(_servo(self.bus, dxl_id, number, protocol), bps))
        result.missing = [i for i in wanted if i not in where] if ids is not None else []
        self._at(result.placed[0].baudrate if result.placed else self.first)
        return result

    def again(self, ids: Sequence[int], rates: Sequence[int]) -> list[Placed]:
        """Those of ``ids`` that answer now at one of ``rates`` (a quick look for servos plugged in
        since; one ping per ID and rate), the bus left at the rate it was at. A model the control
        table lacks is left out."""
        before = self.bus.baudrate
        try:
            where = self._where(sorted(set(ids)), False, list(rates), self.for_ids)
        finally:
            self._at(before)
        placed = []
        for dxl_id, (bps, number, protocol) in sorted(where.items()):
            try:
                placed.append(Placed(_servo(self.bus, dxl_id, number, protocol), bps))
            except StepFailed:
                continue
        return placed

    def everywhere(self, also: Collection[int] = ()) -> list[tuple[int, int, int]]:
        """(ID, rate, model number) of every servo answering at every rate looked at, one ID at
        two rates listed twice (restore looks there for a replacement); the bus at the first rate.
        Protocol 2.0 servos, and those of the protocols ``also`` names (an ID answering both is
        listed once, in 2.0)."""
        seen = []
        for bps in self.rates():
            if self._at(bps):
                seen += [(dxl_id, bps, number) for dxl_id, (number, _) in
                         self._answering(range(253), (2, *also)).items()]
        self._at(self.first)
        return seen

    def one(self, dxl_id: int) -> Servo:
        """The servo at ``dxl_id``, the bus left at its rate; StepFailed when it answers nowhere."""
        found = self.find([dxl_id])
        if not found.placed:
            raise StepFailed(found.why_missing(dxl_id))
        self._at(found.placed[0].baudrate)
        return found.placed[0].servo

    def every(self) -> Found:
        """Every servo on the bus; StepFailed when none answers."""
        found = self.find(None)
        if not found.placed:
            rates = found.rates
            where = f"{rates[0]} bps" if len(rates) == 1 else "any baud rate"
            hint = "" if 1 in self.for_all else (" in Protocol 2.0 (Protocol 1.0 servos: give their IDs, or --protocol "
                                                 "both to ping every ID in Protocol 1.0 too)")
            raise StepFailed(f"no servo answers at {where} on {self.bus.device}{hint}")
        return found
