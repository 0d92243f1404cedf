"""A small, deterministic motor model for the virtual servos.

The point is not motor physics but behaviour a controller notices: a position goal is
approached along a trapezoidal velocity profile capped by the profile velocity and
acceleration; velocity goals ramp at the profile acceleration; PWM and current goals settle
with a first-order lag. Where the command carries a ``ServoLoop`` (Protocol 2.0 servos), the
profile is the reference of a position loop that the shaft follows as the Position P, I and D
Gains say (``servo_loop``); without one (Protocol 1.0 servos) the shaft is on the profile. State
is advanced lazily by elapsed time (closed form where possible, 1 ms sub-steps only while a
position move is under way), so an idle bus costs no CPU.

Everything here is in the servo's *raw* frame (encoder pulses, pulses/s, pulses/s^2), before
homing offset and drive-mode reverse are applied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .servo_loop import LoopState, ServoLoop, loop_velocity, settled

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
    loop: ServoLoop | None = None  # position modes: the servo loop between profile and shaft


def profile_kind(distance: float, vmax: float, amax: float) -> int:
    """The e-Manual's moving-status profile code: 0 step, 1 rectangular, 2 triangular, 3 trapezoidal."""
    if math.isinf(vmax) and math.isinf(amax):
        return 0
    if math.isinf(amax):
        return 1
    if math.isinf(vmax) or abs(distance) < vmax * vmax / amax:
        return 2
    return 3


def profile_step(p: float, v: float, h: float, cmd: Command) -> tuple[float, float]:
    """The profile's position and velocity ``h`` seconds on, towards ``cmd.target_p``: the
    velocity ramps at the profile acceleration up to the profile velocity and down in time to stop
    on the target (where it lands exactly)."""
    target = cmd.target_p
    assert target is not None
    d = target - p
    direction = 1.0 if d > 0 else -1.0
    v_stop = math.sqrt(2.0 * cmd.amax * abs(d)) if not math.isinf(cmd.amax) else math.inf
    v_des = direction * min(cmd.vmax, v_stop)
    if math.isinf(v_des) or math.isinf(cmd.amax):
        v_new = v_des
    else:
        step = cmd.amax * h
        v_new = v + max(-step, min(step, v_des - v))
    travel = h * (v_new if math.isinf(v_new) else 0.5 * (v + v_new))
    if abs(d) <= ARRIVE_TOLERANCE or (travel * direction >= abs(d)):
        return target, 0.0
    return p + travel, v_new


class Motor:
    """Shaft state: position (multi-turn, float pulses), velocity and last acceleration; during a
    position move under a servo loop, the profile's reference as well."""

    def __init__(self, position: float = 0.0) -> None:
        self.p = float(position)
        self.v = 0.0
        self.a = 0.0
        #: the profile's reference and the loop's integral, while a looped position move is under way
        self.loop_state: LoopState | None = None

    def stop(self) -> None:
        self.v = 0.0
        self.a = 0.0
        self.loop_state = None

    def reference(self) -> tuple[float, float]:
        """The profile's position and velocity (the shaft's own when no loop is following one)."""
        if self.loop_state is None:
            return self.p, self.v
        return self.loop_state.r, self.loop_state.rv

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
            self.loop_state = None
            self._advance_velocity(dt, cmd)
            return
        if cmd.loop is None:
            self.loop_state = None
        remaining = dt
        while remaining > 0.0:
            if self.at_target(cmd):
                self.a = 0.0
                self.loop_state = None
                return
            h = POSITION_STEP_S if remaining > POSITION_STEP_S else remaining
            v0 = self.v
            if cmd.loop is None:
                self.p, self.v = profile_step(self.p, self.v, h, cmd)
            else:
                self._loop_step(h, cmd, cmd.loop)
            self.a = (self.v - v0) / h
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

    def _loop_step(self, h: float, cmd: Command, loop: ServoLoop) -> None:
        """One sub-step of a looped move: the profile advances, the shaft follows it."""
        target = cmd.target_p
        assert target is not None
        state = self.loop_state
        if state is None:  # a move starts: the profile sets out from where the shaft is
            state = self.loop_state = LoopState(self.p, self.v)
        state.r, state.rv = profile_step(state.r, state.rv, h, cmd)
        self.v = loop_velocity(loop, state, self.p, self.v, h)
        self.p += h * self.v
        if settled(state, target, self.p, self.v, ARRIVE_TOLERANCE):
            self.p, self.v = target, 0.0
            self.loop_state = None
