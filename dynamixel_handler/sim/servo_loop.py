"""The position loop of a virtual Protocol 2.0 servo: how its shaft follows the profile, from
the Position P, I and D Gains.

The profile generator (``motion.profile_step``: trapezoidal, Profile Velocity and Acceleration)
gives a reference position ``r`` and velocity ``rv``. The servo's loop drives the motor with a
fraction ``u`` of full PWM, and the motor's speed follows the drive with a mechanical lag::

    e  = r - p                                    (pulses)
    u  = clamp((K*e + Kd*(rv - v) + Ki*integral(e dt)) / v_top, -u_max, u_max)
    dv/dt = (v_top*u - v) / TAU_S,   dp/dt = v

``v_top`` is the Velocity Limit (full PWM turns the shaft at that speed), ``u_max`` the PWM Limit
over full scale. The gains are read as multiples of the model's own factory Position P Gain
``P_f`` (the e-Manual's Initial Value: 800 on an XM430), so every model behaves alike at its
factory gains; the ratios follow the X e-Manual's controller (KPP = P/128, KPI = I/65536,
KPD = D/16, derivative and integral over a 1 ms control period)::

    K  = K_F * P/P_f                  (1/s)    stiffness
    Kd = K_F * 8 ms * D/P_f           (-)      damping
    Ki = K_F * (1000/512) s^-1 * I/P_f (1/s^2) integral

Unsaturated, this is ``TAU_S*p'' + (1 + Kd)*p' + K*p = K*r + Kd*rv``: a second-order response,
natural frequency ``sqrt(K/TAU_S)``, damping ratio ``(1 + Kd) / (2*sqrt(K*TAU_S))``. With ``K_F`` =
20/s and ``TAU_S`` = 20 ms the factory gains give about 0.8 (an overshoot of about 1.5 % on a step
reference); P twice the factory with D 0 about 0.56 (12 %); a low P an overdamped, slow approach.
No feedforward (the X factory Feedforward gains are 0): cruising at a profile velocity ``rv`` the
shaft lags the profile by ``rv/K`` (40 pulses, 3.4 deg, at 782 pulses/s and factory P), and the
Position Trajectory registers tell the profile. Not modelled: the motor's electrical dynamics,
friction, backlash, load (so no steady error for I to remove), the Feedforward 1st/2nd Gains, and
the goal current's torque cap in ``cur_position``.

Each step (at most 1 ms) is semi-implicit: the new velocity solves the drive equation with the
damping taken at the end of the step (clamped drive: the saturated solution), then the position
moves at the new velocity. This is stable for every gain in range (a growing damping only slows
the velocity update; P's term needs h^2*K/TAU_S < 4, and the largest P of any model gives 0.34); the
integral is clamped to what full PWM can balance (no wind-up beyond it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

K_F = 20.0  # 1/s: the stiffness at the factory Position P Gain
TAU_S = 0.020  # s: the mechanical lag of the shaft's speed behind the drive
D_TIME_S = 0.008  # s: Kd per (D/P_f), with K_F: 8 * 1 ms (X: KPD/KPP = 8 D/P, per 1 ms)
I_RATE = 1000.0 / 512.0  # 1/s: Ki per (K_F * I/P_f) (X: KPI/KPP = I/(512 P), per 1 ms)
#: the shaft settles (snaps onto the goal) within half a pulse and this slow (pulses/s)
SETTLE_VELOCITY = 40.0


@dataclass(frozen=True)
class ServoLoop:
    """The loop's constants for one servo (see the module's equations)."""

    k: float  # 1/s
    kd: float  # dimensionless
    ki: float  # 1/s^2
    v_top: float  # pulses/s: the shaft's speed at full drive
    u_max: float = 1.0  # the drive's limit, a fraction of full PWM

    @classmethod
    def from_gains(cls, p: float, i: float, d: float, v_top: float, u_max: float = 1.0) -> "ServoLoop":
        """``p``, ``i``, ``d``: the gain registers over the model's factory Position P Gain."""
        return cls(K_F * p, K_F * D_TIME_S * d, K_F * I_RATE * i, max(v_top, 1.0), max(0.0, min(1.0, u_max)))


@dataclass
class LoopState:
    """The shaft against the profile's reference, while a position move is under way."""

    r: float  # pulses: the reference position
    rv: float  # pulses/s: the reference velocity
    integral: float = 0.0  # pulse * s


def loop_velocity(loop: ServoLoop, state: LoopState, p: float, v: float, h: float) -> float:
    """The shaft's velocity after ``h`` seconds (the reference already advanced to the step's end);
    the caller moves the position by ``h`` times it."""
    e = state.r - p
    if loop.ki > 0.0:
        cap = loop.v_top * loop.u_max / loop.ki
        state.integral = max(-cap, min(cap, state.integral + e * h))
    else:
        state.integral = 0.0
    c = h / TAU_S
    # drive * v_top = a - kd * v_new, with a the terms known at the step's start
    a = loop.k * e + loop.kd * state.rv + loop.ki * state.integral
    v_new = (v + c * a) / (1.0 + c * (1.0 + loop.kd))
    drive = (a - loop.kd * v_new) / loop.v_top
    if abs(drive) > loop.u_max:
        v_new = (v + c * loop.v_top * math.copysign(loop.u_max, drive)) / (1.0 + c)
    return v_new


def settled(state: LoopState, target: float, p: float, v: float, tolerance: float) -> bool:
    """The reference is at the goal and the shaft within ``tolerance`` of it, nearly still."""
    return state.r == target and state.rv == 0.0 and abs(target - p) <= tolerance and abs(v) <= SETTLE_VELOCITY
