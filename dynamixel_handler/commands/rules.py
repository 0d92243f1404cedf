"""The rules every command obeys, each in one place, for the per-servo path (``Commander``) and the
vectorised one (``fast_path.FastGoals``) alike: an ID is handled (and of the family asked for), a
value is a finite number, a goal stays within the bounds of its servo (its register range, its
limits, its mode and its family) and is clamped to them with a warning. ROS-free."""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from .. import units
from ..control_table import Model, ServoFamily
from ..core.api import ServoAccess
from .goal_bounds import TableBounds, goal_position_limits
from .tables import MAGNITUDE_LIMIT

#: a goal field of one servo: (ID, value in the field's unit)
Row = tuple[int, float]


def fits(h: ServoAccess, dxl_id: int, family: ServoFamily | None) -> bool:
    """The servo is handled (and of ``family``, or of a family driven through its topics: XL-320
    servos take the X commands, if one is asked for)."""
    if not h.handles(dxl_id):
        return False
    own = h.model(dxl_id).family
    return family is None or own is family or own.topics is family


def all_finite(values: list[float]) -> bool:
    """Every value a finite number (a sum too large also answers False: then each is checked)."""
    return math.isfinite(sum(values))


class Rules:
    """The checks of one commander: finite values and each servo's bounds, with its warnings."""

    def __init__(self, h: ServoAccess, warn: Callable[[str], None], bounds: TableBounds) -> None:
        self.h = h
        self.warn = warn
        self.bounds = bounds

    def finite(self, what: str, field: str, dxl_id: int, value: float) -> bool:
        """False, with a warning, for a float that is NaN or infinite."""
        if isinstance(value, float) and not math.isfinite(value):
            self.warn(f"{what}: ID {dxl_id} '{field}' = {value} refused (not a finite number)")
            return False
        return True

    def limits(self, dxl_id: int, item: str, model: Model) -> tuple[int | None, int | None]:
        """The pulses ``item`` may take on this servo now (the range its e-Manual page gives, or its
        register's, narrowed by its limits, its mode and its family)."""
        if item == "goal_position":
            return goal_position_limits(self.h, dxl_id, model)
        lo, hi = model.value_range(item)
        bound_item = MAGNITUDE_LIMIT.get(item)
        if item.startswith("profile_") and model.family.profile_max is not None:
            bound_item = None  # X: the register's own range, not Velocity Limit
        bound = self.h.value(dxl_id, bound_item) if bound_item is not None and model.has(bound_item) else None
        if bound is not None and bound > 0:
            return (max(lo, -bound), min(hi, bound)) if item.startswith("goal_") else (0, min(hi, bound))
        if item.startswith("profile_"):
            return model.family.profile_bounds(hi)
        return lo, hi

    def clamp(self, what: str, field: str, dxl_id: int, item: str, value: float, pulses: int) -> int:
        """``pulses`` within the servo's bounds; a warning naming the value when it was not."""
        model = self.h.model(dxl_id)
        lo, hi = self.limits(dxl_id, item, model)
        if lo is not None and hi is not None and not lo <= pulses <= hi:
            clamped = min(max(pulses, lo), hi)
            shown = float(units.pulse_to_unit([model], item, [clamped])[0])
            self.warn(f"ID {dxl_id} ({model.name}) '{field}' = {value:g} is beyond the servo's limit: clamped to {shown:g}")
            pulses = clamped
        if units.under_one_step(model, item, value):
            pulses = max(pulses, 1)
            step = float(units.pulse_to_unit([model], item, [1])[0])
            self.warn(f"ID {dxl_id} ({model.name}) '{field}' = {value:g} is less than one step of {item} "
                      f"({step:g}): written as {step:g}, not as 0, which the servo takes for no limit")
        return pulses

    def clamp_rows(self, what: str, field: str, item: str, rows: list[Row], pulses: np.ndarray) -> list[int]:
        """``clamp`` of every row; goal positions the table shows within their bounds all at once."""
        inside = self.bounds.within(self.h.table, [i for i, _ in rows], pulses) if item == "goal_position" else None
        return [raw if inside is not None and inside[k] else self.clamp(what, field, dxl_id, item, value, raw)
                for k, ((dxl_id, value), raw) in enumerate(zip(rows, pulses.tolist()))]

    def to_pulses(self, what: str, field: str, dxl_id: int, item: str, value: float) -> int | None:
        """Units -> pulses for one servo, clamped to its bounds with a warning; None (a warning) if
        its model has no such item."""
        model = self.h.model(dxl_id)
        if not model.has(item):
            self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: '{field}' ignored")
            return None
        return self.clamp(what, field, dxl_id, item, value, int(units.unit_to_pulse([model], item, [value])[0]))
