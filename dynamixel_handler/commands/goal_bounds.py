"""Goal position bounds and checked ID lists as table maths. ROS-free, no I/O, no warnings.

A goal position is bounded by the servo's mode, its position limits and its family
(``ServoFamily.goal_position_bounds``). ``goal_position_limits`` gives one servo's bounds (reading
a limit from the servo when the table lacks it); ``TableBounds`` gives every servo's at once from
the table's arrays, kept until the mode or limit arrays are replaced or the servos change;
``Targets`` is an ID list checked once (handled, once each, of the family asked for) with what the
vectorised path needs of it. What the tables cannot vouch for is for the per-servo rules
(``rules.Rules``), which warn and clamp.
"""
from __future__ import annotations

import math
import operator
from functools import lru_cache
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from .. import units
from ..control_table import Model
from ..servo.table import ServoTable

if TYPE_CHECKING:
    from ..core.api import ServoAccess


@lru_cache(maxsize=64)
def _limited_mode_values(models: tuple[Model, ...]) -> np.ndarray:
    """Per model, the operating mode value whose goal positions stay within the position limits
    (each model's own value: the XL-320's joint mode is 2); -1 where it has none."""
    values = [next((v for name, v in m.mode_values.items() if name in m.position_limited_modes), -1) for m in models]
    out = np.array(values, dtype=np.int64)
    out.setflags(write=False)
    return out


#: the bounds of every servo of a table: (lo, hi, ok) arrays; ok False where the table lacks a
#: value they need
Bounds = tuple[np.ndarray, np.ndarray, np.ndarray]


def _bounds_of(table: ServoTable) -> Bounds:
    n = len(table)
    modes, mode_known = table.pulses("operating_mode"), table.known("operating_mode")
    position = (modes == _limited_mode_values(tuple(table.models))) & mode_known
    bounds = np.array([model_bounds(m) for m in table.models], dtype=np.int64).reshape(n, 4)
    lo = np.where(position, bounds[:, 0], bounds[:, 2])
    hi = np.where(position, bounds[:, 1], bounds[:, 3])
    limits_known = table.known("min_position_limit") & table.known("max_position_limit")
    a, b = table.pulses("min_position_limit"), table.pulses("max_position_limit")
    valid = position & limits_known & (a <= b)
    lo, hi = np.where(valid, a, lo), np.where(valid, b, hi)
    ok = mode_known & (limits_known | ~position)
    return lo, hi, ok


def _positions(table: ServoTable, ids: Sequence[int]) -> np.ndarray | None:
    found = [table.index.get(i) for i in ids]
    if not found or None in found:
        return None
    return np.array(found, dtype=np.intp)


class TableBounds:
    """The goal position bounds of every servo of a table (as ``goal_position_limits`` gives them,
    from the table alone), kept until the table's mode or limit arrays are replaced (a new read or
    write of them) or its servos change. ``enabled`` False: it vouches for nothing (every goal is
    checked servo by servo; the plain counterpart, for comparisons)."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        #: what the bounds were computed from (arrays held, so the identity compare cannot match
        #: a newer array at a reused address), and the bounds
        self._held: tuple[tuple[Any, ...], Bounds] | None = None

    def of_table(self, table: ServoTable) -> Bounds | None:
        """(lo, hi, ok) per servo of ``table``; None when not enabled."""
        if not self.enabled:
            return None
        key = (table, table.version, *table.arrays("operating_mode"), *table.arrays("min_position_limit"),
               *table.arrays("max_position_limit"))
        held = self._held
        if held is not None and len(held[0]) == len(key) and all(map(operator.is_, held[0], key)):
            return held[1]
        bounds = _bounds_of(table)
        self._held = (key, bounds)
        return bounds

    def within(self, table: ServoTable, ids: list[int], pulses: np.ndarray) -> np.ndarray | None:
        """Per goal: True where ``pulses`` is inside the servo's goal position bounds as the table
        knows them; None when the table lacks a value they need (every goal is checked servo by servo)."""
        bounds, pos = self.of_table(table), _positions(table, ids)
        if bounds is None or pos is None or not bounds[2][pos].all():
            return None
        inside: np.ndarray = (bounds[0][pos] <= pulses) & (pulses <= bounds[1][pos])
        return inside


def goal_position_bounds(table: ServoTable, ids: list[int]) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) pulses per servo, as ``goal_position_limits``; None when the table
    lacks the operating mode of one, or the position limits of one in position mode."""
    pos = _positions(table, ids)
    if pos is None:
        return None
    lo, hi, ok = _bounds_of(table)
    return (lo[pos], hi[pos]) if ok[pos].all() else None


@lru_cache(maxsize=None)
def model_bounds(model: Model) -> tuple[int, int, int, int]:
    """The bounds that depend on the model alone: in position mode without valid position limits
    (lo, hi), then in any other mode (lo, hi)."""
    spec = model.item("goal_position")
    return model.family.goal_position_bounds(spec.min_raw, spec.max_raw, model.position_deg_per_pulse)


def goal_position_limits(h: ServoAccess, dxl_id: int, model: Model) -> tuple[int, int]:
    """One servo's goal position bounds in pulses, from its mode, its position limits (read from
    the servo when the table lacks them) and its model."""
    bounds = model_bounds(model)
    if h.mode(dxl_id) in model.position_limited_modes:
        a, b = h.value(dxl_id, "min_position_limit"), h.value(dxl_id, "max_position_limit")
        if a is not None and b is not None and a <= b:
            return a, b
        return bounds[0], bounds[1]
    return bounds[2], bounds[3]


# ============================================================================ command targets
class Targets:
    """An ID list every ID of which the table handles, once, and of the series asked for (if
    any): ``Commander.known_ids`` gives ``targets`` for it without a warning."""

    def __init__(self, table: ServoTable, ids: tuple[int, ...]) -> None:
        self.table = table
        self.ids = list(ids)
        self.targets = list(enumerate(self.ids))
        self.positions = np.array([table.index[i] for i in ids], dtype=np.intp)
        self.models = tuple(table.model(i) for i in ids)
        self._has: dict[str, bool] = {}
        self._mode: tuple[Any, Any, str | None] = (None, None, None)
        self._steps: dict[str, list[tuple[float, float, int, int]]] = {}
        self._bounds: tuple[Any, tuple[list[int], list[int]] | None] = (None, None)

    def has(self, item: str) -> bool:
        """Every servo's model has ``item`` and its unit (``units.unit_to_pulse`` takes it)."""
        found = self._has.get(item)
        if found is None:
            found = self._has[item] = all(model.has(item) for model in self.models) and \
                not units._plan(self.models, item).missing.any()
        return found

    def to_pulses(self, item: str, values: list[float], bounds: tuple[list[int], list[int]] | None
                  ) -> tuple[list[int], bool]:
        """``units.unit_to_pulse`` of finite values in plain Python (a few servos: cheaper than
        numpy's calls), and whether every pulse is within ``bounds``."""
        steps = self._steps.get(item)
        if steps is None:
            plan = units._plan(self.models, item)
            steps = self._steps[item] = list(zip(plan.scale.tolist(), plan.offset.tolist(),
                                                 [int(v) for v in plan.lo.tolist()], [int(v) for v in plan.hi.tolist()]))
        out = []
        floor = 1 if item in units.ZERO_IS_UNLIMITED else 0  # a slow profile, never "no limit"
        for value, (scale, offset, lo, hi) in zip(values, steps):
            scaled = value / scale + offset
            if scaled >= hi:  # rounding keeps it there (and an infinity has no integer)
                raw = hi
            elif scaled <= lo:
                raw = lo
            else:
                raw = math.trunc(scaled + math.copysign(0.5, scaled))  # half away from zero
            out.append(floor if raw == 0 and value > 0 else raw)
        if bounds is None:
            return out, False
        return out, all(map(operator.le, bounds[0], out)) and all(map(operator.le, out, bounds[1]))

    def bounds(self, table_bounds: Bounds | None) -> tuple[list[int], list[int]] | None:
        """The servos' goal position bounds out of the table's (``TableBounds.of_table``):
        (lows, highs); None when the table lacks a value they need."""
        if table_bounds is None:
            return None
        if self._bounds[0] is not table_bounds:
            lo, hi, ok = table_bounds
            pos = self.positions
            self._bounds = (table_bounds, (lo[pos].tolist(), hi[pos].tolist()) if ok[pos].all() else None)
        return self._bounds[1]

    def mode(self) -> str | None:
        """The mode every servo is in as the table knows it (``ServoIO.mode``); None when one's is
        unknown or they differ."""
        raw, known = self.table.arrays("operating_mode")
        held = self._mode
        if raw is held[0] and known is held[1]:
            return held[2]
        name = None
        if raw is not None and known is not None and known[self.positions].all():
            names = {m.mode_name(v) for m, v in zip(self.models, raw[self.positions].tolist())}
            name = names.pop() if len(names) == 1 else None
        self._mode = (raw, known, name)
        return name
