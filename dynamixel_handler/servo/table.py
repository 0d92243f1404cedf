"""The in-memory table of handled servos: what was read (pulses, when) and what waits to be written.

Values are kept per item as int64 arrays aligned with ``ids`` (sorted), so one numpy call converts
an item of every servo to physical units. ROS-free and bus-free; the loop fills it, the ROS layer
reads snapshots of it. Writers (command callbacks) and the loop meet only in ``PendingWrites``,
which has its own lock.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np

from .. import units
from ..control_table import Model


class ServoTable:
    """Handled servos in ID order, with the last value read of every item."""

    def __init__(self) -> None:
        self.ids: list[int] = []
        self.models: list[Model] = []
        self.index: dict[int, int] = {}
        self._raw: dict[str, np.ndarray] = {}
        self._known: dict[str, np.ndarray] = {}
        self.read_time: dict[str, float] = {}
        self.ping = np.zeros(0, dtype=bool)
        self.no_response = np.zeros(0, dtype=np.int64)
        self.version = 0  # bumps whenever the set of servos changes
        # told each ID removed from now on (``watch_removals``), in the order they were registered
        self._removal_watchers: list[Callable[[int], None]] = []
        self._units: dict[str, np.ndarray] = {}  # item -> units of the values now held
        # values the host set itself (written, or read one by one): a sequence number per
        # (item, ID), so a group read sent before them never overwrites them (``newer_than``)
        self.seq = 0
        self._set_at: dict[tuple[str, int], int] = {}
        self._item_set_at: dict[str, int] = {}
        self._positions: dict[tuple[int, ...], np.ndarray] = {}  # ``positions`` of this version
        self._conversions: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # item -> units.conversion
        self._positions_version = -1

    # -------------------------------------------------------------- membership
    def __len__(self) -> int:
        return len(self.ids)

    def __contains__(self, dxl_id: int) -> bool:
        return dxl_id in self.index

    def model(self, dxl_id: int) -> Model:
        return self.models[self.index[dxl_id]]

    def add(self, dxl_id: int, model: Model) -> None:
        if dxl_id in self.index:
            self.models[self.index[dxl_id]] = model
            self.version += 1
            self._units.clear()
            self._conversions.clear()
            return
        pos = int(np.searchsorted(np.asarray(self.ids, dtype=np.int64), dxl_id))
        self.ids.insert(pos, dxl_id)
        self.models.insert(pos, model)
        for name in list(self._raw):
            self._raw[name] = np.insert(self._raw[name], pos, 0)
            self._known[name] = np.insert(self._known[name], pos, False)
        self.ping = np.insert(self.ping, pos, True)
        self.no_response = np.insert(self.no_response, pos, 0)
        self._reindex()

    def watch_removals(self, forget: Callable[[int], None]) -> None:
        """``forget(id)`` runs once for each servo removed from now on, after the table let it go:
        a part that keeps something per servo drops it there (a removal is an event the parts
        observe, whoever removed the servo)."""
        self._removal_watchers.append(forget)

    def remove(self, dxl_id: int) -> None:
        """Stop holding the servo (nothing when it is not held); every watcher is told."""
        pos = self.index.get(dxl_id)
        if pos is None:
            return
        del self.ids[pos]
        del self.models[pos]
        for name in list(self._raw):
            self._raw[name] = np.delete(self._raw[name], pos)
            self._known[name] = np.delete(self._known[name], pos)
        self.ping = np.delete(self.ping, pos)
        self.no_response = np.delete(self.no_response, pos)
        self._set_at = {key: seq for key, seq in self._set_at.items() if key[1] != dxl_id}
        self._reindex()
        for forget in self._removal_watchers:
            forget(dxl_id)

    def positions(self, ids: tuple[int, ...]) -> np.ndarray:
        """The positions of those of ``ids`` handled now, in their order (read-only; kept until the
        set of servos changes)."""
        if self._positions_version != self.version or len(self._positions) > 64:
            self._positions, self._positions_version = {}, self.version
        found = self._positions.get(ids)
        if found is None:
            index = self.index
            found = np.array([pos for pos in map(index.get, ids) if pos is not None], dtype=np.intp)
            found.setflags(write=False)
            self._positions[ids] = found
        return found

    def _reindex(self) -> None:
        self.index = {dxl_id: i for i, dxl_id in enumerate(self.ids)}
        self.version += 1
        self._units.clear()
        self._conversions.clear()

    # -------------------------------------------------------------- values
    def store(self, item: str, positions: np.ndarray, pulses: np.ndarray, when: float) -> None:
        """Record pulses read for the servos at ``positions``."""
        if item not in self._raw:
            self._raw[item] = np.zeros(len(self.ids), dtype=np.int64)
            self._known[item] = np.zeros(len(self.ids), dtype=bool)
        # copy on write: snapshots (``snapshot``) share the arrays they were taken with
        raw, known = self._raw[item].copy(), self._known[item].copy()
        raw[positions] = pulses
        known[positions] = True
        self._raw[item], self._known[item] = raw, known
        self.read_time[item] = when
        self._units.pop(item, None)

    def snapshot(self) -> "ServoTable":
        """A frozen copy of what the table holds now, for another thread (the publishing one).
        Cheap: value arrays are replaced, never changed in place, so they are shared."""
        snap = ServoTable.__new__(ServoTable)
        snap.ids, snap.models, snap.index = list(self.ids), list(self.models), self.index
        snap._raw, snap._known, snap._units = dict(self._raw), dict(self._known), dict(self._units)
        snap.read_time = dict(self.read_time)
        snap.ping, snap.no_response = self.ping.copy(), self.no_response.copy()
        snap.version = self.version
        snap.seq, snap._set_at, snap._item_set_at = self.seq, {}, {}
        snap._positions, snap._positions_version = {}, -1
        snap._conversions = dict(self._conversions)
        return snap

    def set_value(self, item: str, dxl_id: int, pulses: int) -> None:
        """Record a value known without a group read (e.g. one just written and confirmed)."""
        pos = self.index[dxl_id]
        self.store(item, np.array([pos]), np.array([pulses], dtype=np.int64), self.read_time.get(item, 0.0))
        self.note_set(item, (dxl_id,))

    def note_set(self, item: str, ids: Iterable[int]) -> None:
        """``item`` of ``ids`` was just set by the host: group reads sent before keep off it."""
        self.seq += 1
        for dxl_id in ids:
            self._set_at[(item, dxl_id)] = self.seq
        self._item_set_at[item] = self.seq

    def newer_than(self, item: str, ids: Sequence[int], seq: int) -> list[int]:
        """Those of ``ids`` whose ``item`` the host set after sequence number ``seq``."""
        if self._item_set_at.get(item, 0) <= seq:
            return []
        return [i for i in ids if self._set_at.get((item, i), 0) > seq]

    def pulses(self, item: str) -> np.ndarray:
        """Last pulses of ``item`` per servo (0 where never read)."""
        raw = self._raw.get(item)
        return raw.copy() if raw is not None else np.zeros(len(self.ids), dtype=np.int64)

    def known(self, item: str) -> np.ndarray:
        known = self._known.get(item)
        return known.copy() if known is not None else np.zeros(len(self.ids), dtype=bool)

    def arrays(self, item: str) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(pulses, known) of ``item`` as stored, not copied: replaced on every store, never changed
        in place, so the same objects mean the same values (None: never stored). Do not modify."""
        return self._raw.get(item), self._known.get(item)

    def value(self, item: str, dxl_id: int) -> int | None:
        pos = self.index.get(dxl_id)
        if pos is None or item not in self._raw or not self._known[item][pos]:
            return None
        return int(self._raw[item][pos])

    def units(self, item: str) -> np.ndarray:
        """Last value of ``item`` per servo in physical units; NaN where unknown or not on the model.
        Converted once per new read (several messages of one loop share it); do not modify."""
        cached = self._units.get(item)
        if cached is not None:
            return cached
        raw, known = self.arrays(item)
        if raw is None or known is None:
            raw, known = np.zeros(len(self.ids), dtype=np.int64), np.zeros(len(self.ids), dtype=bool)
        conversion = self._conversions.get(item)
        if conversion is None:  # kept until the servos or their models change
            conversion = self._conversions[item] = units.conversion(self.models, item)
        offset, scale = conversion
        out: np.ndarray = (raw - offset) * scale  # units.pulse_to_unit, without the models looked up again
        if not known.all():
            out[~known] = np.nan
        out.setflags(write=False)
        self._units[item] = out
        return out


@dataclass
class PendingWrites:
    """Values waiting for the next loop: the last value per (item, ID) wins, nothing is lost."""

    _items: dict[str, dict[int, int]] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def put(self, item: str, values: Mapping[int, int]) -> None:
        with self._lock:
            self._items.setdefault(item, {}).update(values)

    def put_many(self, writes: Iterable[tuple[str, Mapping[int, int]]]) -> None:
        with self._lock:
            for item, values in writes:
                self._items.setdefault(item, {}).update(values)

    def peek(self, item: str) -> dict[int, int]:
        """The values of ``item`` waiting to be written (a copy)."""
        with self._lock:
            return dict(self._items.get(item, {}))

    def take(self) -> dict[str, dict[int, int]]:
        """Everything pending, emptied atomically."""
        with self._lock:
            taken, self._items = self._items, {}
        return taken

    def forget(self, dxl_id: int) -> None:
        """Drop what waits for a servo no longer handled."""
        self.drop_ids((dxl_id,))

    def drop_items(self, items: Iterable[str]) -> None:
        """Forget what waits to be written to ``items`` (an E-stop drops the goals waiting)."""
        with self._lock:
            for item in items:
                self._items.pop(item, None)

    def drop_ids(self, ids: Sequence[int]) -> None:
        with self._lock:
            for values in self._items.values():
                for dxl_id in ids:
                    values.pop(dxl_id, None)

    def __bool__(self) -> bool:
        with self._lock:
            return any(self._items.values())
