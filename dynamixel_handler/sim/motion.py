"""A small, deterministic motor model for the virtual servos.

The point is not motor physics but behaviour a controller notices: a position goal is
approached along a trapezoidal velocity profile capped by the profile velocity and
acceleration; velocity goals ramp at the profile acceleration; PWM and current goals settle
with a first-order lag. State is advanced lazily by elapsed time (closed form where possible,
1 ms sub-steps only while a position move is under way), so an idle bus costs no CPU.

Everything here is in the servo's *raw* frame (encoder pulses, pulses/s, pulses/s^2), before
homing offset and drive-mode reverse are applied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

POSITION_STEP_S = 0.001
ARRIVE_TOLERANCE = 0.5  # pulses


@dataclass
class Command:
    """What the servo's controller asks of the motor over an interval."""

    torque: bool = False
    target_v: float = 0.0  # pulses/s, for velocity-like modes
    target_p: float | None = None  # pulses, for position modes (None otherwise)
    vmax: float = math.inf  # pulses/s, profile velocity cap
    amax: float = math.inf  # pulses/s^2, profile acceleration (inf: instant)
    lag_s: float = 0.0  # > 0: first-order lag instead of a ramp (PWM / current modes)


def profile_kind(distance: float, vmax: float, amax: float) -> int:
    """The e-Manual's moving-status profile code: 0 step, 1 rectangular, 2 triangular, 3 trapezoidal."""
    if math.isinf(vmax) and math.isinf(amax):
        return 0
    if math.isinf(amax):
        return 1
    if math.isinf(vmax) or abs(distance) < vmax * vmax / amax:
        return 2
    return 3


class Motor:
    """Shaft state: position (multi-turn, float pulses), velocity and last acceleration."""

    def __init__(self, position: float = 0.0) -> None:
        self.p = float(position)
        self.v = 0.0
        self.a = 0.0

    def stop(self) -> None:
        self.v = 0.0
        self.a = 0.0

    def at_target(self, cmd: Command) -> bool:
        return cmd.target_p is not None and self.p == cmd.target_p and self.v == 0.0

    def advance(self, dt: float, cmd: Command) -> None:
        """Move the state forward by ``dt`` seconds under ``cmd``."""
        if dt <= 0.0:
            return
        if not cmd.torque:
            self.stop()
            return
        if cmd.target_p is None:
            self._advance_velocity(dt, cmd)
            return
        remaining = dt
        while remaining > 0.0:
            if self.at_target(cmd):
                self.a = 0.0
                return
            h = POSITION_STEP_S if remaining > POSITION_STEP_S else remaining
            self._position_step(h, cmd)
            remaining -= h

    def _advance_velocity(self, dt: float, cmd: Command) -> None:
        v0, vt = self.v, cmd.target_v
        if cmd.lag_s > 0.0:
            decay = math.exp(-dt / cmd.lag_s)
            self.p += vt * dt + (v0 - vt) * cmd.lag_s * (1.0 - decay)
            self.v = vt + (v0 - vt) * decay
        elif math.isinf(cmd.amax) or v0 == vt:
            self.p += vt * dt
            self.v = vt
        else:
            ramp = abs(vt - v0) / cmd.amax
            direction = 1.0 if vt > v0 else -1.0
            if ramp >= dt:
                v1 = v0 + direction * cmd.amax * dt
                self.p += 0.5 * (v0 + v1) * dt
                self.v = v1
            else:
                self.p += 0.5 * (v0 + vt) * ramp + vt * (dt - ramp)
                self.v = vt
        self.a = (self.v - v0) / dt

    def _position_step(self, h: float, cmd: Command) -> None:
        target = cmd.target_p
        assert target is not None
        d = target - self.p
        v0 = self.v
        direction = 1.0 if d > 0 else -1.0
        v_stop = math.sqrt(2.0 * cmd.amax * abs(d)) if not math.isinf(cmd.amax) else math.inf
        v_des = direction * min(cmd.vmax, v_stop)
        if math.isinf(v_des):
            v_new = v_des
        elif math.isinf(cmd.amax):
            v_new = v_des
        else:
            dv = v_des - v0
            step = cmd.amax * h
            v_new = v0 + max(-step, min(step, dv))
        travel = h * (v_new if math.isinf(v_new) else 0.5 * (v0 + v_new))
        if abs(d) <= ARRIVE_TOLERANCE or (travel * direction >= abs(d)):
            self.p = target
            self.v = 0.0
            self.a = (0.0 - v0) / h
            return
        self.p += travel
        self.v = v_new
        self.a = (v_new - v0) / h
