"""One Moving Speed register for two goals: on the models without Profile Velocity whose speed of a
move is Moving Speed (XL-320, Protocol 1.0), it is the velocity goal in Wheel Mode (velocity) and
the speed of a move in Joint Mode (position modes), where 0 means "as fast as the motor goes"."""
from __future__ import annotations

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
    family = model.family
    if item not in SPEED_ITEMS or model.has("profile_velocity") or family.move_speed_field != "profile_vel_deg_s":
        return item
    position = h.mode(dxl_id) in POSITION_MODES
    if field == family.move_speed_field:
        return family.speed_item(False) if position else None
    return None if position else item


def not_fastest(h: ServoAccess, warn: Callable[[str], None], what: str, item: str, rows: list[Row],
                pulses: Sequence[int]) -> list[int]:
    """Moving Speed 0 in a position mode, on a model whose family says it means "as fast as the
    motor goes" (``fastest_at_zero``), written as 1, the slowest it takes, with one line."""
    out = list(pulses)
    if item != "goal_velocity":
        return out
    for k, (dxl_id, _) in enumerate(rows):
        if out[k] == 0 and h.model(dxl_id).family.fastest_at_zero and h.mode(dxl_id) in POSITION_MODES:
            out[k] = 1
            warn(f"{what}: ID {dxl_id} speed 0: Moving Speed 0 would move it as fast as the motor goes in "
                 "Joint Mode; written as 1, the slowest it takes")
    return out
