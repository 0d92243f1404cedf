"""Which items this loop reads, as which sync reads, and how the replies are stored."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np

from ..bus import ServoBus
from ..bus.ops import SyncRead
from ..servo.groups import GROUP_ITEMS, PRESENT, due
from ..servo.table import ServoTable
from ..settings import ReadRatios
from ..units import from_sign_magnitude
from .pacing import REPLY_BYTES, SYNC_READ_BYTES, Pacing
from .servo_io import Log

#: items closer than this many bytes are read in one span when method/split_read is false
SPAN_GAP = 24
#: Fast Sync Reads in a row that must stop at a servo which answers the plain Sync Read before it is
#: taken for firmware without Fast Sync Read (a garbled reply or a neighbour's silence does it once)
FAST_MISSES_PLAIN = 3


@dataclass(frozen=True)
class ReadSettings:
    ratios: ReadRatios
    fast_read: bool = False     # Method.fast_read: Fast Sync Read
    split_read: bool = False    # Method.split_read: one read per item, not spans over small gaps


def every(ratios: ReadRatios) -> int:
    """The smallest ratio above 0 (how often the most often read items are read); 0: none."""
    return min((r for r in ratios.all() if r > 0), default=0)


@dataclass(frozen=True)
class ReadPart:
    item: str
    offset: int
    size: int
    signed: bool
    #: sign-magnitude items (XL-320 speeds, load): the bit that carries the direction; 0: none
    direction_bit: int = 0


#: one item of a model as a read plan sees it: (name, address, size, signed, direction bit)
_Sig = tuple[str, int, int, bool, int]
#: items due (in reading order), present keys, groups, and the items sorted without repeats
_Due = tuple[tuple[str, ...], frozenset[str], frozenset[str], tuple[str, ...]]


def due_items_plain(ratios: ReadRatios, loop: int) -> _Due:
    """``ReadPlan.due_items`` worked out from the ratios for one loop."""
    present_keys = {k for k in PRESENT if due(ratios.present[k], loop)}
    groups = {g for g, ratio in ratios.groups.items() if due(ratio, loop)}
    items: list[str] = [PRESENT[k][0] for k in PRESENT if k in present_keys]
    for g in groups:
        items += [i for i in GROUP_ITEMS[g] if i not in items]
    return tuple(items), frozenset(present_keys), frozenset(groups), tuple(sorted(set(items)))


@dataclass(frozen=True)
class Read:
    """One sync read: ``length`` bytes from ``address`` of the servos ``ids``, which hold ``parts``."""

    address: int
    length: int
    ids: tuple[int, ...]
    parts: tuple[ReadPart, ...]
    fast: bool = False
    #: the servos' protocol (1: no Sync Read, each read on its own)
    protocol: int = 2


class ReadPlan:
    """Pub ratios -> the items due -> sync reads grouped by control-table layout (cached); while bus
    watchdogs are armed, a read is no longer on the wire than its share of the shortest (``pacing``).
    Replies gathered (a Fast Sync Read that stopped short completed by a plain one) and stored."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, pacing: Pacing, settings: ReadSettings) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.pacing = pacing
        self.settings = settings  # replaced as a whole when the parameters are (never changed in place)
        self._plans: dict[tuple[tuple[str, ...], bytes], list[Read]] = {}
        self._plans_version = -1
        #: the shortest armed bus watchdog time [s] the cached plans were cut for
        self._plans_armed: float | None = None
        # loops' due items by the pattern of ratios that divide the loop number
        self._due_for: ReadSettings | None = None
        self._due_cache: dict[tuple[bool, tuple[int, ...]], _Due] = {}
        self._due_ratios: tuple[int, ...] = ()
        self.plain_read: set[int] = set()  # IDs that do not answer Fast Sync Read
        self._fast_misses: dict[int, int] = {}  # ID -> fast reads in a row that stopped at it while it answered plain

    def due_items(self, loop: int) -> tuple[list[str], set[str], set[str]]:
        """The items read in loop ``loop``, the present keys and the groups they make up."""
        items, present_keys, groups, _ = self.due(loop)
        return list(items), set(present_keys), set(groups)

    def due(self, loop: int) -> _Due:
        """``due_items`` (and the items sorted, without repeats), worked out once per pattern: which
        groups are due depends only on which of the configured ratios divide ``loop``."""
        settings = self.settings
        if self._due_for is not settings:
            ratios = settings.ratios
            self._due_for, self._due_cache = settings, {}
            self._due_ratios = tuple(sorted(set(ratios.all())))
        key = (loop == 0, tuple(r for r in self._due_ratios if r > 0 and loop % r == 0))
        found = self._due_cache.get(key)
        if found is None:
            found = self._due_cache[key] = due_items_plain(settings.ratios, loop)
        return found

    def plan(self, items: tuple[str, ...], live: np.ndarray) -> list[Read]:
        """Sync reads for ``items`` over the live servos, grouped by control-table layout (cached);
        spans cut to what the shortest armed bus watchdog allows (``Pacing.read_span_limit``)."""
        self._plans_fresh()
        key = (items, live.tobytes())
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        layouts: dict[tuple[int, bool, tuple[_Sig, ...]], list[int]] = {}
        fast_read = self.settings.fast_read
        for pos, model in enumerate(self.table.models):
            if not live[pos]:
                continue
            sig = tuple((i, model.items[i].address, model.items[i].size, model.items[i].signed,
                         model.items[i].direction_bit) for i in items if model.has(i))
            protocol = model.protocol
            # the faster group read where the servo takes it: Fast Sync Read (2.0, method/fast_read),
            # Bulk Read (1.0: MX and EX; the others are read one by one)
            fast = model.family.reads_fast(fast_read) and self.table.ids[pos] not in self.plain_read
            if sig:
                layouts.setdefault((protocol, fast, tuple(sorted(sig, key=lambda s: s[1]))), []).append(pos)
        plan = []
        for (protocol, fast, sig), positions in layouts.items():
            ids = tuple(self.table.ids[p] for p in positions)
            for address, length, parts in _spans(sig, self.settings.split_read, self.pacing.read_span_limit(len(ids))):
                plan.append(Read(address, length, ids, parts, fast, protocol))
        self._plans[key] = plan
        return plan

    def _plans_fresh(self) -> None:
        """Forget the cached plans when the servos or the shortest armed bus watchdog changed."""
        armed = self.pacing.shortest_armed_s()
        if self._plans_version != self.table.version or armed != self._plans_armed:
            self._plans.clear()
            self._plans_version, self._plans_armed = self.table.version, armed

    def wire_s_per_loop(self) -> float:
        """Wire time of the reads over every handled servo (instruction and replies at the baud
        rate, plus the adapter's latency each way) per loop, on average over the loops between two
        reads of the most often read items."""
        most = every(self.settings.ratios)
        if not len(self.table) or not self.bus.baudrate or not most:
            return 0.0
        items, _, _ = self.due_items(most)  # the loop that reads the most often read items
        if not items:
            return 0.0
        live = np.ones(len(self.table), dtype=bool)
        byte_s = 10.0 / self.bus.baudrate
        latency_s = 2 * self.bus.latency_timer_ms / 1000.0
        total = 0.0
        for read in self.plan(tuple(sorted(set(items))), live):
            n = len(read.ids)
            total += (SYNC_READ_BYTES + n + n * (REPLY_BYTES + read.length)) * byte_s + latency_s
        return total / most  # per loop, on average

    def gather(self, read: Read, data: dict[int, bytes]) -> dict[int, bytes]:
        """One read's replies, completed by a plain Sync Read where a Fast Sync Read stopped short."""
        if read.fast and self._fast_misses:
            for dxl_id in data:  # answered the fast read: a miss before was not its firmware
                self._fast_misses.pop(dxl_id, None)
        if read.fast and len(data) < len(read.ids):
            data = self._read_plain(read, data)
        return data

    def _read_plain(self, read: Read, data: dict[int, bytes]) -> dict[int, bytes]:
        """Read the servos a Fast Sync Read missed with a plain Sync Read.

        The servos answer a fast read in a chain, which stops at the first one that does not answer
        (silent, its segment garbled, or firmware without Fast Sync Read: old Pro "-R", early X and
        P); those after it were only cut off. So only that first one can lack the instruction: if it
        answers the plain read FAST_MISSES_PLAIN times in a row, it is read so from now on."""
        missing = [i for i in read.ids if i not in data]
        plain = self.bus.execute(SyncRead(read.address, read.length, tuple(missing), protocol=read.protocol)).value
        first = missing[0]
        if first in plain:
            self._fast_misses[first] = self._fast_misses.get(first, 0) + 1
            if self._fast_misses[first] >= FAST_MISSES_PLAIN:
                del self._fast_misses[first]
                self.log.info(f"ID {first}: no answer to Fast Sync Read, read with Sync Read from now on")
                self.plain_read.add(first)
                self._plans.clear()
        return {**data, **plain}

    def store(self, read: Read, data: dict[int, bytes], stamp: float, seq: int | None = None) -> None:
        """Store replies; values the host set after the read went out (sequence ``seq``) are newer and kept."""
        index = self.table.index
        positions = self.table.positions(read.ids)
        if len(data) == len(read.ids) == len(positions):  # all answered, none removed meanwhile
            ok_ids: Sequence[int] = read.ids
        else:
            ok_ids = [i for i in read.ids if i in data and i in index]  # an operation may have removed one meanwhile
            if not ok_ids:
                return
            positions = np.fromiter((index[i] for i in ok_ids), dtype=np.int64, count=len(ok_ids))
        for part, values in zip(read.parts, decode_replies(read, b"".join(data[i] for i in ok_ids))):
            newer = self.table.newer_than(part.item, ok_ids, seq) if seq is not None else []
            if newer:
                keep = np.array([i not in newer for i in ok_ids])
                self.table.store(part.item, positions[keep], values[keep], stamp)
            else:
                self.table.store(part.item, positions, values, stamp)


def decode_replies(read: Read, joined: bytes) -> list[np.ndarray]:
    """The values (int64, one per reply) of each part of ``read`` from its replies end to end:
    read through a record dtype when every part is 1, 2 or 4 bytes (always, for Dynamixel items),
    else byte by byte (``decode_replies_plain``, which gives the same values)."""
    record = _record(read.length, read.parts)
    if record is None:
        return decode_replies_plain(read, joined)
    rows = np.frombuffer(joined, dtype=record)
    return [_signed(part, rows[part.item].astype(np.int64)) for part in read.parts]


def _signed(part: ReadPart, values: np.ndarray) -> np.ndarray:
    """Sign-magnitude values as signed numbers (others as they are)."""
    return from_sign_magnitude(values, part.direction_bit) if part.direction_bit else values


def decode_replies_plain(read: Read, joined: bytes) -> list[np.ndarray]:
    """``decode_replies`` one byte column at a time (any part size)."""
    buf = np.frombuffer(joined, dtype=np.uint8).reshape(-1, read.length)
    out = []
    for part in read.parts:
        cols = buf[:, part.offset:part.offset + part.size].astype(np.int64)
        values = cols @ (np.int64(1) << (8 * np.arange(part.size, dtype=np.int64)))
        if part.signed:
            half = np.int64(1) << (8 * part.size - 1)
            values = np.where(values >= half, values - 2 * half, values)
        out.append(_signed(part, values))
    return out


@lru_cache(maxsize=512)
def _record(length: int, parts: tuple[ReadPart, ...]) -> np.dtype | None:
    """One reply as a numpy record: each part a little-endian integer field at its offset."""
    if not parts or any(p.size not in (1, 2, 4) for p in parts) or len({p.item for p in parts}) < len(parts):
        return None
    return np.dtype({"names": [p.item for p in parts],
                     "formats": [f"<{'i' if p.signed else 'u'}{p.size}" for p in parts],
                     "offsets": [p.offset for p in parts], "itemsize": length})


def _spans(sig: Sequence[_Sig], split: bool,
           longest: int | None = None) -> list[tuple[int, int, tuple[ReadPart, ...]]]:
    """Cut items (sorted by address) into read spans: one per item, or merged across small gaps
    into spans of at most ``longest`` bytes (None: any length; an item longer stays whole)."""
    spans: list[tuple[int, int, list[_Sig]]] = []
    for member in sig:
        _, address, size, _, _ = member
        if (spans and not split and address - (spans[-1][0] + spans[-1][1]) <= SPAN_GAP
                and (longest is None or max(spans[-1][1], address + size - spans[-1][0]) <= longest)):
            start, _, members = spans[-1]
            end = max(start + spans[-1][1], address + size)
            spans[-1] = (start, end - start, members + [member])
        else:
            spans.append((address, size, [member]))
    return [(start, length, tuple(ReadPart(i, a - start, s, sg, d) for i, a, s, sg, d in members))
            for start, length, members in spans]
