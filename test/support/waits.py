"""Waiting for what a user would see: a simulated servo's registers, a published state field."""
from __future__ import annotations

import math

from .rig import Rig


def regs(rig: Rig, dxl_id: int, *items: str) -> dict[str, int]:
    """The simulated servo's registers by item name, raw."""
    servo = rig.sim.servo(dxl_id)
    return {item: servo.read(item) for item in items}


#: registers a failed wait shows, where the servo has them: what keeps a shaft from moving, mostly
SHOWN = ("torque_enable", "operating_mode", "goal_position", "present_position", "goal_velocity", "present_velocity",
         "profile_velocity", "profile_acceleration", "velocity_limit", "min_position_limit", "max_position_limit",
         "homing_offset", "goal_current", "hardware_error_status", "bus_watchdog")


def shown(rig: Rig, dxl_id: int) -> str:
    """The servo's ``SHOWN`` registers as a line of a failure message."""
    servo = rig.sim.servo(dxl_id)
    return f"ID {dxl_id} holds " + ", ".join(f"{k} {servo.read(k)}" for k in SHOWN if servo.model.has(k))


def wait_regs(rig: Rig, dxl_id: int, expected: dict[str, int], timeout: float = 10.0) -> None:
    """Wait until the servo's registers hold ``expected``; fail showing what they hold."""
    try:
        rig.wait(lambda: regs(rig, dxl_id, *expected) == expected, timeout=timeout, what=f"ID {dxl_id} registers")
    except AssertionError:
        held = regs(rig, dxl_id, *expected, "operating_mode", "torque_enable")
        assert {k: held[k] for k in expected} == expected, (
            f"ID {dxl_id} registers after {timeout:g} s: {held}, want {expected}\nnode output:\n{rig.output[-3000:]}")


def _matches(value: object, target: object, tol: float) -> bool:
    if value is None:
        return False
    if isinstance(target, (bool, str)):
        return value == target
    assert isinstance(target, (int, float)) and isinstance(value, (int, float))
    if math.isnan(target):
        return math.isnan(value)
    return not math.isnan(value) and abs(value - target) <= tol


def wait_state(rig: Rig, group: str, field: str, dxl_id: int, target: object, tol: float = 1e-6,
               timeout: float = 10.0) -> None:
    """Wait until the published ``group.field`` of the servo is ``target`` (within ``tol``; NaN for
    "not supported"; a bool or string exactly); fail naming the last value."""
    try:
        rig.wait(lambda: _matches(rig.state_of(group, field, dxl_id), target, tol), timeout=timeout,
                 what=f"ID {dxl_id} {group}.{field} -> {target}")
    except AssertionError as exc:
        raise AssertionError(f"{exc} (last {rig.state_of(group, field, dxl_id)}); {shown(rig, dxl_id)}") from None
