"""One Moving Speed register for two goals: on the models without Profile Velocity whose speed of a
move is Moving Speed (XL-320, Protocol 1.0), it is the velocity goal in Wheel Mode (velocity) and
the speed of a move in Joint Mode (position modes), where 0 means "as fast as the motor goes"."""
from __future__ import annotations

from functools import partial
from typing import Callable, Sequence

from ..control_table import POSITION_MODES
from ..core.api import ServoAccess
from .fast_path import SPEED_ITEMS
from .rules import Row
from .tables import GOAL_FIELDS


def goal_item(h: ServoAccess, field: str, dxl_id: int) -> str | None:
    """The item a goal field of ``command/goal`` goes to. On a model whose Moving Speed is both
    goals: ``profile_vel_deg_s`` goes to it in position modes, ``velocity_deg_s`` in velocity mode,
    and the other is not written (it would change the one the servo's mode uses)."""
    item = GOAL_FIELDS.get(field)
    model = h.model(dxl_id)
    behaviour = model.family.behaviour
    if item not in SPEED_ITEMS or not behaviour.speed_in_position_only(model):
        return item
    position = h.mode(dxl_id) in POSITION_MODES
    if field == behaviour.speed_field:
        return behaviour.speed_item(model) if position else None
    return None if position else item


def not_fastest(h: ServoAccess, warn: Callable[[str], None], what: str, item: str, rows: list[Row],
                pulses: Sequence[int]) -> list[int]:
    """Moving Speed 0 in a position mode, on a model whose family says it means "as fast as the
    motor goes" (its behaviour's ``speed_pulses``), written as 1, the slowest it takes, with one line."""
    out = list(pulses)
    if item != "goal_velocity":
        return out
    for k, (dxl_id, _) in enumerate(rows):
        written = h.model(dxl_id).family.behaviour.speed_pulses(out[k], partial(h.mode, dxl_id))
        if written != out[k]:
            out[k] = written
            warn(f"{what}: ID {dxl_id} speed 0: Moving Speed 0 would move it as fast as the motor goes in "
                 "Joint Mode; written as 1, the slowest it takes")
    return out
