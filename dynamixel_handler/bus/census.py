"""Who answers on a bus, and where two servos share an ID: the scan that the node's start-up and
the set-up tool's scan share.

Two servos at one ID both answer every packet addressed to it; on the half-duplex line their
replies collide. That shows as CRC errors, as bytes read that made no valid reply (overlapping
replies), or as a second complete reply after an answered ping. A scan whose reply train was
clean found one servo at each ID; a garbled one is followed by a few pings of each ID found (and
of each ID that gave noise instead of an answer) to tell which IDs are shared, in rounds that
must all say so. A reply that is merely late (a loaded host) is none of these: it can make one
round look shared (its bytes come in a later ping's time, or in another ID's), not every round.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Iterable

from ..protocol.framers import FRAMERS
from .api import ServoBus
from .ops import Ping
from .reads import BROADCAST_SCAN_MIN_IDS

#: pings that tell a shared ID from a clean one
CLEAN_PINGS = 3
#: rounds of those pings that must all look shared: two servos at one ID garble every round, a
#: late reply (a loaded host, or another ID's reply arriving in this ID's pings) only the odd one
SHARED_ROUNDS = 3
#: quiet time before each further round, for late replies to arrive and be dropped [s]
SETTLE_S = 0.03
#: bytes of a Protocol 2.0 ping's status
PING_REPLY_BYTES = 14


@dataclass
class Census:
    """The servos that answered ``{id: model number}`` and the IDs where two or more answer
    (``shared``: the model number one of them gave, or None when no reply came through whole)."""

    found: dict[int, int] = field(default_factory=dict)
    shared: dict[int, int | None] = field(default_factory=dict)


def _ping(bus: ServoBus, dxl_id: int, pause_s: float, *, protocol: int) -> int | None:
    model: int | None = bus.execute(Ping(dxl_id, retries=0, protocol=protocol)).value
    if pause_s:
        time.sleep(pause_s)
    return model


def probe(bus: ServoBus, dxl_id: int, pings: int, *, protocol: int) -> tuple[int | None, bool]:
    """Ping ``dxl_id`` ``pings`` times: (its model number or None, whether two servos seem to answer).
    A second complete reply is counted when the next ping flushes the input, so with ``pings`` > 1
    the first ping only flushes what came before. A Protocol 1.0 ping is a ping and a read of the
    model number: 6 + 8 bytes of replies, as many as a Protocol 2.0 ping's status."""
    # a second servo's reply may come up to a Return Delay Time (508 us at most) after the first one:
    # each ping waits for it, so the next ping's input flush counts it instead of taking it as its answer
    pause_s = (0.0015 + 2 * PING_REPLY_BYTES * 10.0 / bus.baudrate) if pings > 1 else 0.0
    first = _ping(bus, dxl_id, pause_s, protocol=protocol) if pings > 1 else None
    stats = bus.stats
    crc, rx, discarded = stats.crc_errors, stats.bytes_rx, stats.discarded_bytes
    models = [_ping(bus, dxl_id, pause_s, protocol=protocol) for _ in range(max(1, pings - 1))]
    answered = [m for m in models if m is not None]
    garbled = stats.crc_errors != crc or stats.bytes_rx - rx > len(answered) * PING_REPLY_BYTES
    if pings > 1 and len(answered) == len(models):
        garbled = garbled or stats.discarded_bytes != discarded
    return (answered[0] if answered else first), garbled


def census(bus: ServoBus, ids: Iterable[int], broadcast: bool | None = None, thorough: bool = False,
           *, protocol: int) -> Census:
    """Scan ``ids`` (see ``DynamixelBus.scan``) and tell the shared IDs: each ID found is pinged a
    few times more when the reply train was garbled, when the scan pinged ID by ID (a second
    reply to a unicast ping is seen only by the next transaction), or when ``thorough``.
    ``protocol`` 1: Protocol 1.0 servos, which have no broadcast ping: pinged ID by ID."""
    wanted = sorted(set(ids))
    before = noise(bus)
    broadcast = FRAMERS[protocol].broadcast_ping and (len(wanted) >= BROADCAST_SCAN_MIN_IDS if broadcast is None
                                                      else broadcast)
    answered = _answered(bus, wanted, broadcast, protocol)
    out = Census()
    garbled = noise(bus) != before
    if not (garbled or thorough or not broadcast):
        out.found = answered
        return out
    for dxl_id in wanted:
        if dxl_id in answered or (garbled and _noisy(bus, dxl_id, protocol=protocol)):
            probed, shared = rounds(bus, dxl_id, protocol=protocol)
            number = answered.get(dxl_id, probed)
            if shared:
                out.shared[dxl_id] = number
            elif number is not None:
                out.found[dxl_id] = number
    return out


def _answered(bus: ServoBus, wanted: list[int], broadcast: bool, protocol: int) -> dict[int, int]:
    """{ID: model number} of the first pings: the bus's scan, or a ping per ID in a protocol without a
    broadcast ping (1.0)."""
    if not FRAMERS[protocol].broadcast_ping:
        return {i: n for i in wanted if (n := _ping(bus, i, 0.0, protocol=protocol)) is not None}
    return bus.scan(wanted, broadcast)


def rounds(bus: ServoBus, dxl_id: int, *, protocol: int) -> tuple[int | None, bool]:
    """``probe`` in up to ``SHARED_ROUNDS`` rounds: (a model number it gave, whether every round
    looked shared)."""
    # the last ping's input flush is the next one's: one more than needed counts doubled replies
    probed, shared = probe(bus, dxl_id, CLEAN_PINGS + 2, protocol=protocol)
    for _ in range(SHARED_ROUNDS - 1):
        if not shared:
            break
        time.sleep(SETTLE_S)
        again, shared = probe(bus, dxl_id, CLEAN_PINGS + 2, protocol=protocol)
        probed = probed if probed is not None else again
    return probed, shared


def noise(bus: ServoBus) -> int:
    """The bus's count of bytes that made no valid reply and of CRC errors (it grows when replies
    collide)."""
    return bus.stats.crc_errors + bus.stats.discarded_bytes


def _noisy(bus: ServoBus, dxl_id: int, *, protocol: int) -> bool:
    """Whether an ID the garbled scan did not find answers a ping, or gives noise."""
    quick, noisy = probe(bus, dxl_id, 1, protocol=protocol)
    return quick is not None or noisy
