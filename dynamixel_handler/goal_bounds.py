"""Goal positions checked against their limits for many servos at once (the command fast path).

``Commander._goal_position_limits`` finds one servo's bounds from its mode, its position limits
and its model, reading a value from the servo when the table lacks it. ``within`` answers the
common question, "is every goal inside its bounds?", with a few numpy operations: the bounds of
every servo are computed once and kept until the table's mode or limit arrays are replaced (a new
read or write of them) or its servos change. The goals it cannot vouch for (outside, or a value the
table lacks) take the per-servo path, which clamps and warns. Both give the same pulses and the
same warnings (tested).
"""
from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from .command_tables import MAX_ROTATION, X_MULTI_TURN_GOAL
from .control_table import Model
from .groups import MODE_NAMES
from .servos import ServoTable

#: False: every goal takes the per-servo path (the plain counterpart, for tests and comparisons)
ENABLED = True
#: operating mode values whose goal positions stay within the position limits
POSITION_MODE = [value for value, name in MODE_NAMES.items() if name == "position"]


def within(table: ServoTable, ids: list[int], pulses: np.ndarray) -> np.ndarray | None:
    """Per goal: True where ``pulses`` is inside the servo's goal position bounds as the table
    knows them; None when the table lacks a value they need (every goal takes the per-servo path)."""
    if not ENABLED:
        return None
    lo, hi, ok = _table_bounds(table)
    index = table.index
    found = [index.get(i) for i in ids]
    if not found or None in found:
        return None
    pos = np.array(found, dtype=np.intp)
    if not ok[pos].all():
        return None
    inside: np.ndarray = (lo[pos] <= pulses) & (pulses <= hi[pos])
    return inside


def goal_position_bounds(table: ServoTable, ids: list[int]) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) pulses per servo, as ``Commander._goal_position_limits``; None when the table
    lacks the operating mode of one, or the position limits of one in position mode."""
    lo, hi, ok = _table_bounds(table)
    found = [table.index.get(i) for i in ids]
    if not found or None in found:
        return None
    pos = np.array(found, dtype=np.intp)
    return (lo[pos], hi[pos]) if ok[pos].all() else None


#: the bounds of every servo of a table, with what they were computed from (arrays held, so the
#: identity compare cannot match a newer array at a reused address)
_cache: dict[int, tuple[tuple[Any, ...], tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}


def _table_bounds(table: ServoTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, ok) per servo of the table; ok False where the table lacks a value they need."""
    key = (table, table.version, *table.arrays("operating_mode"), *table.arrays("min_position_limit"),
           *table.arrays("max_position_limit"))
    hit = _cache.get(id(table))
    if hit is not None and len(hit[0]) == len(key) and all(a is b for a, b in zip(hit[0], key)):
        return hit[1]
    n = len(table)
    modes, mode_known = table.pulses("operating_mode"), table.known("operating_mode")
    position = np.isin(modes, POSITION_MODE) & mode_known
    bounds = np.array([model_bounds(m) for m in table.models], dtype=np.int64).reshape(n, 4)
    lo = np.where(position, bounds[:, 0], bounds[:, 2])
    hi = np.where(position, bounds[:, 1], bounds[:, 3])
    limits_known = table.known("min_position_limit") & table.known("max_position_limit")
    a, b = table.pulses("min_position_limit"), table.pulses("max_position_limit")
    valid = position & limits_known & (a <= b)
    lo, hi = np.where(valid, a, lo), np.where(valid, b, hi)
    ok = mode_known & (limits_known | ~position)
    if len(_cache) > 16:
        _cache.clear()
    _cache[id(table)] = (key, (lo, hi, ok))
    return lo, hi, ok


@lru_cache(maxsize=None)
def model_bounds(model: Model) -> tuple[int, int, int, int]:
    """The bounds that depend on the model alone: in position mode without valid position limits
    (lo, hi), then in any other mode (lo, hi)."""
    spec = model.item("goal_position")
    lo, hi = spec.min_raw, spec.max_raw
    if model.series == "X":
        return lo, hi, max(lo, -X_MULTI_TURN_GOAL), min(hi, X_MULTI_TURN_GOAL)
    turns = int(round(MAX_ROTATION * 360.0 / model.position_deg_per_pulse))
    return max(lo, -turns), min(hi, turns), max(lo, -turns), min(hi, turns)
