"""The command fast path: goals for many servos checked at once.

``Commander`` checks a command servo by servo: that its IDs are handled and of the series, that
each servo is in the control's mode, that each value is a finite number the servo's model takes,
then each goal against its bounds (``goal_position_limits``: from the servo's mode, its position
limits and its model, reading a value from the servo when the table lacks it). For the common
command, every ID handled once, of the series, already in the mode, every value finite, the
answers hardly ever change, so they are kept:

- ``Targets``: an ID list checked once per servo table version (a servo added, removed or its
  model changed) and series, with the servos' places in the table, their models, which items they
  all have and the mode they are all in (kept until the table's mode array is replaced);
- ``within``: "is every goal position inside its bounds?" in a few numpy operations: the bounds of
  every servo are computed once and kept until the table's mode or limit arrays are replaced (a new
  read or write of them) or its servos change.

What they cannot vouch for (an unknown or repeated ID, a servo in another mode, a value that is
not finite, a goal outside its bounds, a value the table lacks) takes the per-servo path, which
warns, changes modes and clamps. Both give the same pulses, writes and warnings (tested).
"""
from __future__ import annotations

import math
import operator
from functools import lru_cache
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from . import units
from .command_tables import GOAL_FIELDS
from .control_table import POSITION_LIMITED_MODES, POSITION_MODES, Model, ServoFamily
from .groups import MODE_NAMES
from .servos import ServoTable

if TYPE_CHECKING:
    from .commands import Commander
    from .core.api import ServoAccess

#: False: every goal takes the per-servo path (the plain counterpart, for tests and comparisons)
ENABLED = True
#: False: every command takes the per-servo checks (``Targets`` unused; for tests and comparisons)
TARGETS = True
#: commands for at most this many servos are converted in plain Python, more through numpy
SMALL = 32
#: operating mode values whose goal positions stay within the position limits
POSITION_MODE = [value for value, name in MODE_NAMES.items() if name in POSITION_LIMITED_MODES]


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
    """(lo, hi) pulses per servo, as ``goal_position_limits``; None when the table
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
    if hit is not None and len(hit[0]) == len(key) and all(map(operator.is_, hit[0], key)):
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
    return model.family.goal_position_bounds(spec.min_raw, spec.max_raw, model.position_deg_per_pulse)


def goal_position_limits(h: ServoAccess, dxl_id: int, model: Model) -> tuple[int, int]:
    """One servo's goal position bounds in pulses, from its mode, its position limits (read from
    the servo when the table lacks them) and its model."""
    bounds = model_bounds(model)
    if h.mode(dxl_id) in POSITION_LIMITED_MODES:
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
        for value, (scale, offset, lo, hi) in zip(values, steps):
            scaled = value / scale + offset
            if scaled >= hi:  # rounding keeps it there (and an infinity has no integer)
                out.append(hi)
            elif scaled <= lo:
                out.append(lo)
            else:
                out.append(math.trunc(scaled + math.copysign(0.5, scaled)))  # half away from zero
        if bounds is None:
            return out, False
        return out, all(map(operator.le, bounds[0], out)) and all(map(operator.le, out, bounds[1]))

    def bounds(self) -> tuple[list[int], list[int]] | None:
        """The servos' goal position bounds as the table knows them (``within``): (lows, highs);
        None when the table lacks a value they need."""
        if not ENABLED:
            return None
        table_bounds = _table_bounds(self.table)
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
            names = {MODE_NAMES.get(v) for v in raw[self.positions].tolist()}
            name = names.pop() if len(names) == 1 else None
        self._mode = (raw, known, name)
        return name


#: per table: (table, its version, {(ids, series): Targets or None})
_targets: dict[int, tuple[ServoTable, int, dict[tuple[tuple[int, ...], ServoFamily | None], Targets | None]]] = {}


def targets(c: Commander, ids: Sequence[int], series: ServoFamily | None) -> Targets | None:
    """The ``Targets`` of ``ids`` (of ``series``), or None: an ID unknown, repeated, of another
    series, or none at all (``known_ids`` checks them one by one, warning)."""
    if not TARGETS or not ids:
        return None
    plans = _plans(c.h.table)
    key = (tuple(ids), series)
    try:
        return plans[key]
    except KeyError:
        pass
    except TypeError:  # an ID that is no number
        return None
    if len(plans) > 64:
        plans.clear()
    h = c.h
    unique = len(set(key[0])) == len(key[0])
    fit = unique and all(h.handles(i) and (series is None or h.model(i).family is series) for i in key[0])
    plan = plans[key] = Targets(h.table, key[0]) if fit else None
    return plan


def _plans(table: ServoTable) -> dict[tuple[tuple[int, ...], ServoFamily | None], Targets | None]:
    """The ``Targets`` of the table as its servos are now (forgotten when they change)."""
    held = _targets.get(id(table))
    if held is None or held[0] is not table or held[1] != table.version:
        if len(_targets) > 16:
            _targets.clear()
        held = _targets[id(table)] = (table, table.version, {})
    return held[2]


Work = list[tuple[str, str, list[float]]]


def fast_goals(c: Commander, what: str, ids: Sequence[int], fields: Mapping[str, Sequence[Any]],
               series: ServoFamily | None = None, mode: str | None = None) -> bool:
    """``Commander._goal`` (``mode`` None) or ``Commander._control`` when every ID is handled
    once, of the series and in ``mode``, and every value a finite number the models take: the
    goals go to ``Commander.put_writes``, True. False, with nothing done: the per-servo path."""
    plan = targets(c, ids, series)
    if plan is None or (mode is not None and plan.mode() != mode):
        return False
    work = _work(plan, fields, series, mode)
    if work is None:
        return False
    if mode is not None:
        for dxl_id in plan.ids:
            c.h.cancel_deferred(dxl_id)  # a later request wins over a waiting mode change
    writes: dict[str, dict[int, int]] = {}
    for field, item, values in work:
        writes.setdefault(item, {}).update(zip(plan.ids, _pulses(c, plan, what, field, item, values)))
    c.put_writes(what, writes)
    return True


def _pulses(c: Commander, plan: Targets, what: str, field: str, item: str, values: list[float]) -> list[int]:
    """The pulses of one field's values; those outside their bounds (or all, when the table lacks
    a value the bounds need) clamped servo by servo, with the warnings."""
    goal_position = item == "goal_position"
    if len(values) <= SMALL:
        raws, inside = plan.to_pulses(item, values, plan.bounds() if goal_position else None)
        if inside:
            return raws
        pulses = np.array(raws, dtype=np.int64)
    else:
        pulses = units.unit_to_pulse(plan.models, item, values)
        bounds = _table_bounds(c.h.table) if goal_position and ENABLED else None
        if bounds is not None and bounds[2][plan.positions].all() and \
                ((bounds[0][plan.positions] <= pulses) & (pulses <= bounds[1][plan.positions])).all():
            return list(pulses.tolist())
    return c._clamp_rows(what, field, item, list(zip(plan.ids, values)), pulses)


def _speed_per_model(series: ServoFamily | None, field: str, mode: str | None) -> bool:
    """True where ``field`` is the speed of a move whose item depends on each servo's model."""
    return series is not None and series.speed_item_is_per_model and field == series.move_speed_field \
        and mode in POSITION_MODES


def _work(plan: Targets, fields: Mapping[str, Sequence[Any]], series: ServoFamily | None, mode: str | None) -> Work | None:
    """(field, item, values) of each goal field, in the message's order; None if one needs the
    per-servo path (a value not a finite float, an item a model lacks, rotation on a control topic)."""
    work = []
    for field, values in fields.items():
        if field == "rotation":
            if mode is not None:  # control topics: the turns go into the position goals
                return None
            continue
        item = GOAL_FIELDS.get(field)
        if item is None:
            continue
        if _speed_per_model(series, field, mode):
            return None  # the item depends on the model
        array = np.asarray(values)
        if array.dtype != np.float64 or array.shape != (len(plan.ids),) or not plan.has(item):
            return None
        floats = array.tolist()
        if not math.isfinite(sum(floats)):  # a NaN or an infinity (or a sum too large: checked one by one)
            return None
        work.append((field, item, floats))
    return work
