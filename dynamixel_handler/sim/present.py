"""The present-value registers a virtual servo's shaft writes at each refresh: position, velocity,
the profile's trajectory, current (or load), PWM, voltage, temperature, Realtime Tick, Moving, Moving
Status and the external port data, each where the model has the item. Present Position reads within
the goal position range in multi-turn mode (MX 1.0: ±28,672); a current item offset reads its zero
without current (MX Current: 2048); a model without a current limit takes a representative 2 A as its
full output's current.
"""

from __future__ import annotations

from typing import Protocol

from .firmware import Firmware
from .frames import Frame
from .motion import Command, Motor
from .registers import Registers

_ANALOG_INPUT = 2048
#: the current at the full output where a model has no Current Limit (mA)
_FULL_OUTPUT_MA = 2000.0


class Shaft(Protocol):
    """What the present values are written from (``dynamics.Dynamics``)."""

    frame: Frame
    firmware: Firmware
    motor: Motor
    supply_v: float
    ambient_c: int
    pinned: dict[str, int]
    port_latch: dict[int, int]
    profile_kind: int

    @property
    def registers(self) -> Registers: ...
    @property
    def boot(self) -> float: ...
    def output(self) -> bool: ...
    def command(self) -> Command: ...
    def mode(self) -> str | None: ...
    def load_share(self) -> float: ...
    def user_position(self) -> float: ...
    def scale(self, kind: str) -> float: ...
    def threshold_pulses(self) -> float: ...
    def pwm_full_scale(self) -> int: ...
    def velocity_limit(self) -> float: ...


def publish(d: Shaft, now: float) -> None:
    """Rewrite every present-value register of ``d``'s servo."""
    r = d.registers
    torque = d.output()
    cmd = d.command()
    _motion(d)
    _effort(d, torque)
    volts = r.model.item_scales.get("present_input_voltage", r.model.voltage_v_per_pulse)
    r.poke("present_input_voltage", int(round(d.supply_v / volts)))
    r.poke("realtime_tick", int((now - d.boot) * 1000) % 32768)
    _moving(d, torque, cmd)
    _ports(d)
    for name, value in d.pinned.items():
        r.poke(name, value)


def _motion(d: Shaft) -> None:
    r, s = d.registers, d.frame.sign()
    position = d.user_position()
    bounds = r.model.ranges.get("goal_position")
    if bounds is not None and d.mode() == "ex_position":
        position = max(bounds[0], min(bounds[1], position))
    r.poke("present_position", int(round(position)))
    r.poke("present_velocity", int(round(s * d.motor.v / d.scale("v"))))
    ref_p, ref_v = d.motor.reference()  # the profile's, during a move
    r.poke("position_trajectory", int(round(s * ref_p + r.get("homing_offset"))))
    r.poke("velocity_trajectory", int(round(s * ref_v / d.scale("v"))))


def _full_current(d: Shaft) -> float:
    """Present Current at the full output: Current Limit, or a representative current."""
    r = d.registers
    if r.has("current_limit"):
        return float(r.get("current_limit"))
    if r.has("present_current"):
        return _FULL_OUTPUT_MA / r.model.current_ma_per_pulse
    return 0.0


def _effort(d: Shaft, torque: bool) -> None:
    """Current (or load), PWM and the temperature the current (or the load) heats the servo to."""
    r = d.registers
    mode = d.mode()
    load = d.load_share()
    full = _full_current(d)
    current = r.get("goal_current") if (mode == "current" and torque) else int(round(load * full))
    r.poke("present_current", r.model.item_zero.get("present_current", 0) + current)
    r.poke("present_load", int(round(load * d.firmware.load_full_scale)))
    pwm_full = d.pwm_full_scale()
    if not torque:
        pwm = 0
    elif mode == "pwm":
        pwm = r.get("goal_pwm")
    else:
        s, vlim = d.frame.sign(), d.velocity_limit()
        pwm = int(round((s * d.motor.v / vlim + 0.1 * max(-1.0, min(1.0, s * d.motor.a / (10.0 * vlim)))) * pwm_full))
    pwm_limit = r.get("pwm_limit", pwm_full)
    r.poke("present_pwm", max(-pwm_limit, min(pwm_limit, pwm)))
    heat = abs(current) / full if full else abs(load)
    r.poke("present_temperature", d.ambient_c + (2 if torque else 0) + int(round(8 * heat)))


def _moving(d: Shaft, torque: bool, cmd: Command) -> None:
    r = d.registers
    in_motion = abs(d.motor.v) > d.threshold_pulses()
    ongoing = torque and cmd.target_p is not None and not d.motor.at_target(cmd)
    r.poke("moving", 1 if (in_motion or ongoing) else 0)
    status = 0
    if cmd.target_p is not None and torque:
        status = (0x02 | d.profile_kind << 4) if ongoing else 0x01
    r.poke("moving_status", status)


def _ports(d: Shaft) -> None:
    r = d.registers
    for port in r.model.external_ports:
        mode = r.get(f"external_port_mode_{port}")
        value = {0: _ANALOG_INPUT, 1: d.port_latch.get(port, 0), 2: 1, 3: 0}.get(mode, 0)
        r.poke(f"external_port_data_{port}", value)
