"""The command fast path: goals for many servos checked at once.

``Commander`` checks a command servo by servo: that its IDs are handled and of the family, that
each servo is in the control's mode, that each value is a finite number the servo's model takes,
then each goal against its bounds. For the common command, every ID handled once, of the family,
already in the mode, every value finite, the answers hardly ever change, so they are kept:
``Targets`` per ID list (checked once per servo table version and family) and the bounds of every
servo (``goal_bounds.TableBounds``). What they cannot vouch for (an unknown or repeated ID, a servo
in another mode, a value that is not finite, a goal outside its bounds, a value the table lacks)
takes the per-servo path, which warns, changes modes and clamps, by the same ``rules``. Both give
the same pulses, writes and warnings (tested).
"""
from __future__ import annotations

from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .. import units
from ..control_table import ServoFamily
from ..core.api import ServoAccess
from ..servo.table import ServoTable
from .goal_bounds import Targets
from .paths import CommandPaths
from .rules import Rules, all_finite, fits
from .tables import GOAL_FIELDS

#: the goal items that are one register (Moving Speed) on a model without Profile Velocity
SPEED_ITEMS = ("goal_velocity", "profile_velocity")

#: (field, item, values) of each goal field of a command
Work = list[tuple[str, str, list[float]]]
PlanKey = tuple[tuple[int, ...], "ServoFamily | None"]


class FastGoals:
    """The fast path of one commander (its core ``h``, its ``rules``, its ``paths``)."""

    def __init__(self, h: ServoAccess, rules: Rules, paths: CommandPaths,
                 put_writes: Callable[[str, dict[str, dict[int, int]]], None]) -> None:
        self.h = h
        self.rules = rules
        self.paths = paths
        self.put_writes = put_writes
        #: the ``Targets`` of the table as its servos are now: (table, its version, {key: Targets or None})
        self._plans: tuple[ServoTable | None, int, dict[PlanKey, Targets | None]] = (None, -1, {})

    def targets(self, ids: Sequence[int], family: ServoFamily | None) -> Targets | None:
        """The ``Targets`` of ``ids`` (of ``family``), or None: an ID unknown, repeated, of another
        family, or none at all (``Commander.known_ids`` checks them one by one, warning)."""
        if not self.paths.targets or not ids:
            return None
        table = self.h.table
        held = self._plans
        if held[0] is not table or held[1] != table.version:
            held = self._plans = (table, table.version, {})
        plans = held[2]
        key = (tuple(ids), family)
        try:
            return plans[key]
        except KeyError:
            pass
        except TypeError:  # an ID that is no number
            return None
        if len(plans) > 64:
            plans.clear()
        unique = len(set(key[0])) == len(key[0])
        fit = unique and all(fits(self.h, i, family) for i in key[0])
        plan = plans[key] = Targets(table, key[0]) if fit else None
        return plan

    def goals(self, what: str, ids: Sequence[int], fields: Mapping[str, Sequence[Any]],
              family: ServoFamily | None = None, mode: str | None = None) -> bool:
        """A goal command (``mode`` None) or a control command when every ID is handled once, of
        the family and in ``mode``, and every value a finite number the models take: the goals go
        to ``put_writes``, True. False, with nothing done: the per-servo path."""
        plan = self.targets(ids, family)
        if plan is None or (mode is not None and plan.mode() != mode):
            return False
        work = _work(plan, fields, family, mode)
        if work is None:
            return False
        if mode is not None:
            for dxl_id in plan.ids:
                self.h.core.cancel_deferred(dxl_id)  # a later request wins over a waiting mode change
        writes: dict[str, dict[int, int]] = {}
        for field, item, values in work:
            writes.setdefault(item, {}).update(zip(plan.ids, self._pulses(plan, what, field, item, values)))
        self.put_writes(what, writes)
        return True

    def _pulses(self, plan: Targets, what: str, field: str, item: str, values: list[float]) -> list[int]:
        """The pulses of one field's values; those outside their bounds (or all, when the table lacks
        a value the bounds need) clamped servo by servo, with the warnings."""
        goal_position = item == "goal_position"
        bounds = self.rules.bounds.of_table(self.h.table) if goal_position else None
        if len(values) <= self.paths.small:
            raws, inside = plan.to_pulses(item, values, plan.bounds(bounds))
            if inside:
                return raws
            pulses = np.array(raws, dtype=np.int64)
        else:
            pulses = units.unit_to_pulse(plan.models, item, values)
            pos = plan.positions
            if bounds is not None and bounds[2][pos].all() and \
                    ((bounds[0][pos] <= pulses) & (pulses <= bounds[1][pos])).all():
                return list(pulses.tolist())
        return self.rules.clamp_rows(what, field, item, list(zip(plan.ids, values)), pulses)


def _speed_per_model(family: ServoFamily | None, field: str, mode: str | None) -> bool:
    """True where ``field`` is the speed of a move whose item depends on each servo's model."""
    return family is not None and family.behaviour.speed_per_model(field, mode)


def _work(plan: Targets, fields: Mapping[str, Sequence[Any]], family: ServoFamily | None, mode: str | None) -> Work | None:
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
        if _speed_per_model(family, field, mode):
            return None  # the item depends on the model
        array = np.asarray(values)
        if array.dtype != np.float64 or array.shape != (len(plan.ids),) or not plan.has(item):
            return None
        if item in SPEED_ITEMS and not plan.has("profile_velocity"):
            return None  # Moving Speed: the velocity goal or the speed of a move, by each servo's mode
        floats = array.tolist()
        if not all_finite(floats):  # a NaN or an infinity (or a sum too large: checked one by one)
            return None
        work.append((field, item, floats))
    return work
