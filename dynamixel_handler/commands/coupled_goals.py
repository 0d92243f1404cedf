"""The servo goals of a coupled set of joints (a differential): every servo of the set solved from
the joints' rows (``joints.Coupling``) and written together. ROS-free; loop thread."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable

from ..control_table import KEPT_POSITION_MODES
from ..joints import DEG, Coupling, JointMap

if TYPE_CHECKING:
    from ..core.api import ServoAccess

#: a joint's command: position, velocity, effort (None: not given)
Given = tuple["float | None", "float | None", "float | None"]
#: (control, servo ID, fields in servo units)
Goal = tuple[str, int, dict[str, float]]


def coupled_goals(h: ServoAccess, mapping: JointMap, warn: Callable[[str], None], what: str, coupling: Coupling,
                  given: dict[str, Given]) -> list[Goal]:
    """Positions solved from the joints given and the others' goals; else velocities (the others
    at 0). An effort is not handled (one line)."""
    if any(eff is not None for _, _, eff in given.values()):
        warn(f"{what}: effort of the coupled joints {list(coupling.names)} is not handled: ignored")
    positions = [given[n][0] if n in given else None for n in coupling.names]
    velocities = [given[n][1] if n in given else None for n in coupling.names]
    if any(p is not None for p in positions):
        return _positions(h, warn, what, coupling, positions)
    if any(v is not None for v in velocities):
        return _rates(mapping, coupling, velocities)
    return []


def _rates(mapping: JointMap, coupling: Coupling, velocities: list[float | None]) -> list[Goal]:
    limits = [mapping.joint(n).velocity_limit for n in coupling.names]
    rates = [max(-lim, min(lim, float(v))) if v is not None else 0.0 for v, lim in zip(velocities, limits)]
    return [("velocity_control", dxl_id, {"velocity_deg_s": float(rad_s) / DEG})
            for dxl_id, rad_s in zip(coupling.servo_ids, coupling.rates(rates))]


def _positions(h: ServoAccess, warn: Callable[[str], None], what: str, coupling: Coupling,
               positions: list[float | None]) -> list[Goal]:
    kept = goal_joints(h, coupling)
    wanted = [p if p is not None else q for p, q in zip(positions, kept)]
    if not all(math.isfinite(q) for q in wanted):
        warn(f"{what}: the coupled joints {list(coupling.names)} have no position read yet: ignored")
        return []
    return [("goal" if h.mode(dxl_id) in KEPT_POSITION_MODES else "position_control", dxl_id,
             {"position_deg": float(rad) / DEG}) for dxl_id, rad in zip(coupling.servo_ids, coupling.servos_rad(wanted))]


def goal_joints(h: ServoAccess, coupling: Coupling) -> list[float]:
    """The joints of a coupled set where its servos' last goals put them (their present positions
    where no goal is known): a joint not commanded stays at its goal."""
    table = h.table
    goal, present = table.units("goal_position"), table.units("present_position")
    servo_rad = []
    for dxl_id in coupling.servo_ids:
        p = table.index[dxl_id]
        servo_rad.append((goal[p] if math.isfinite(goal[p]) else present[p]) * DEG)
    return [offset + sum(f * s for f, s in zip(row, servo_rad)) for row, offset in zip(coupling.rows, coupling.offsets)]
