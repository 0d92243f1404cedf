"""One ``/diagnostics`` status per joint, in the joint's units: its position, velocity and effort
as ``joint_states`` has them, its servos, its soft limits, and a level from its servos' (the worst
of them) and its own (beyond its soft limits; the servos of a paired joint apart). ROS-free."""
from __future__ import annotations

import math

from ..servo.health import ERROR, OK, WARN, Health, servo_health
from ..servo.table import ServoTable
from .mapping import DEG, JointMap, read_joints, spread

__all__ = ["joint_health"]


def joint_health(mapping: JointMap, table: ServoTable, prefix: str = "dynamixel_handler") -> list[Health]:
    """A status per joint driven by servos (mimic joints have none of their own)."""
    reading = read_joints(mapping, table)
    at = {n: k for k, n in enumerate(reading.names)}
    out = []
    for joint in mapping.joints:
        unit = "m" if joint.prismatic else "rad"
        h = Health(name=f"{prefix}: joint {joint.name}", hardware_id="dynamixel_ids_" + "_".join(map(str, joint.servo_ids)))
        h.values.append(("servos", ", ".join(f"ID {i}" for i in joint.servo_ids)))
        k = at.get(joint.name)
        if k is None:
            h.raise_to(ERROR, "position unknown: its servo(s) not handled or never read")
        else:
            _state(h, joint.position_limits, unit, mapping.effort_unit, reading.position_rad[k],
                   reading.velocity_rad_s[k], reading.effort_a[k])
        _servos(h, table, joint.servo_ids)
        if joint.partners and joint.coupling is None and k is not None:
            apart = spread(joint, table)
            h.values.append(("servos apart [deg]", f"{apart / DEG:.2f}"))
            if apart > joint.disagreement:
                h.raise_to(WARN, f"its servos disagree by {apart / DEG:.2f} deg")
        out.append(h)
    return out


def _state(h: Health, limits: tuple[float, float], unit: str, effort_unit: str, position: float, velocity: float,
           effort: float) -> None:
    h.values += [(f"position [{unit}]", f"{position:.5g}"), (f"velocity [{unit}/s]", _shown(velocity, 5)),
                 (f"effort [{effort_unit if unit == 'rad' or effort_unit == 'A' else 'N'}]", _shown(effort, 4))]
    lo, hi = limits
    if math.isfinite(lo) or math.isfinite(hi):
        h.values.append((f"limits [{unit}]", f"[{lo:g}, {hi:g}]"))
        if not lo - 1e-9 <= position <= hi + 1e-9:
            h.raise_to(WARN, f"at {position:.4g} {unit}, beyond its soft limits [{lo:g}, {hi:g}]")


def _shown(value: float, digits: int) -> str:
    return "unknown" if math.isnan(value) else f"{value:.{digits}g}"


def _servos(h: Health, table: ServoTable, ids: tuple[int, ...]) -> None:
    """The worst level of the joint's servos, naming the servo and its problem."""
    for dxl_id in ids:
        if dxl_id not in table:
            continue
        servo = servo_health(table, dxl_id)
        if servo.level > OK:
            h.raise_to(servo.level, f"ID {dxl_id}: {servo.message}")
