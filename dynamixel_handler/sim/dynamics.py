"""What a virtual servo's registers say about its shaft, and what the shaft says back.

``Dynamics`` turns the goal registers into a ``Command`` for the motor model, advances the
motor to the time of a request (tripping the bus watchdog on the way when it expires) and writes
every present-value register: position, velocity, current or load, PWM, voltage, temperature,
Realtime Tick, Moving, Moving Status and the external port data.
"""

from __future__ import annotations

import math

from .motion import Command, Motor, profile_kind
from .registers import Registers
from .servo_loop import ServoLoop

#: modes whose goal is a position (by name: the Operating Mode values are the model's own)
POSITION_MODES = ("position", "ex_position", "cur_position")
LAG_S = 0.05
_ANALOG_INPUT = 2048


class Dynamics:
    """Frames (drive mode, homing offset, one-turn folding) and the motor behind the registers:
    the shaft's state, the time it was advanced to, the bus watchdog's last instruction, the
    latched external port outputs and the pinned present values."""

    def __init__(self, registers: Registers, now: float) -> None:
        self._r = registers
        self.motor = Motor()
        self._t = now
        self._boot = now
        #: when the last instruction for this servo arrived (the bus watchdog counts from it)
        self.last_instruction = now
        self._profile_kind = 0
        #: external port outputs written (port -> value)
        self.port_latch: dict[int, int] = {}
        #: present-value items held at a value (name -> value)
        self.pinned: dict[str, int] = {}
        self.supply_v = 12.0
        self.ambient_c = 30

    def restart(self, now: float) -> None:
        """A power cycle: the shaft stops (multi-turn folded to one turn), the outputs drop."""
        self.motor.stop()
        self.motor.p = self.fold(self.motor.p)
        self.port_latch.clear()
        self._boot = now
        self.last_instruction = now

    def goal_position_changed(self) -> None:
        """Moving Status tells the profile of the move to a new goal position."""
        cmd = self.command()
        if cmd.target_p is not None:
            self._profile_kind = profile_kind(cmd.target_p - self.motor.p, cmd.vmax, cmd.amax)

    # ------------------------------------------------------------------ frames
    def _sign(self) -> float:
        return -1.0 if self._r.get("drive_mode") & 0x01 else 1.0

    def _user_position(self) -> float:
        return self._sign() * self.motor.p + self._r.get("homing_offset")

    def _mode(self) -> str | None:
        """The operating mode by name (the XL-320's Control Mode values are its own)."""
        return self._r.model.mode_name(self._r.get("operating_mode"))

    def _revolution(self) -> int:
        if self._r.x:
            return 4096
        model = self._r.model
        if model.position_min_pulse >= 0:  # XL-320: 0..1023 over 300 deg, the rest of a turn unseen
            return int(round(360.0 / model.position_deg_per_pulse))
        return 2 * model.position_max_pulse

    def _unsigned_positions(self) -> bool:
        return self._r.x or self._r.model.position_min_pulse >= 0

    def fold(self, raw: float) -> float:
        rev = self._revolution()
        if self._unsigned_positions():
            return raw % rev
        half = rev // 2
        return ((raw + half) % rev) - half

    def turn_to(self, present: float) -> None:
        """A hand turns the shaft until Present Position reads ``present`` [pulses] (no
        instruction; with torque on the servo drives back to its goal)."""
        self.motor.stop()
        self.motor.p = self._sign() * (present - self._r.get("homing_offset"))

    def hold_if_position_mode(self) -> None:
        if self._mode() in POSITION_MODES:
            self._r.poke("goal_position", int(round(self._user_position())))

    def _scale(self, kind: str) -> float:
        per = {"v": self._r.model.velocity_deg_s_per_pulse, "a": self._r.model.acceleration_deg_ss_per_pulse}[kind]
        return per / self._r.model.position_deg_per_pulse

    def threshold_pulses(self) -> float:
        return self._r.get("moving_threshold") * self._scale("v")

    def _pwm_full_scale(self) -> int:
        return 885 if self._r.x else 2009

    def torque_changed(self, old: int, value: int, now: float) -> None:
        """Torque on: the shaft holds where it is (position modes); off: it stops."""
        if value == 1 and old == 0:
            if self._mode() == "position":
                self.motor.p = self.fold(self.motor.p)
            self.hold_if_position_mode()
            self.last_instruction = now
        elif value == 0:
            self.motor.stop()

    # ------------------------------------------------------------------ command
    def command(self) -> Command:
        torque = self._r.get("torque_enable") == 1
        mode = self._mode()
        s = self._sign()
        vlim = self._velocity_limit()
        if mode in POSITION_MODES:
            return self._position_command(torque, vlim)
        amax = self._profile_acceleration()
        if mode == "velocity":
            return Command(torque, s * self._r.get("goal_velocity") * self._scale("v"), None, vlim, amax)
        if mode == "pwm":
            full = float(self._pwm_full_scale())
            return Command(torque, s * self._r.get("goal_pwm") / full * vlim, None, vlim, math.inf, LAG_S)
        if mode == "current":
            limit = max(self._r.get("current_limit"), 1)
            return Command(torque, s * self._r.get("goal_current") / limit * vlim, None, vlim, math.inf, LAG_S)
        return Command(False)

    def _velocity_limit(self) -> float:
        """The top speed in pulses/s: Velocity Limit, or where a model has none (XL-320) its
        goal velocity's top (1023: the no-load speed)."""
        if self._r.has("velocity_limit"):
            pulses = self._r.get("velocity_limit")
        else:
            goal = self._r.model.items.get("goal_velocity")
            pulses = goal.max_raw if goal is not None else 0
        return max(pulses, 1) * self._scale("v")

    def _profile_acceleration(self) -> float:
        prof_a = self._r.get("profile_acceleration")
        return prof_a * self._scale("a") if prof_a > 0 else math.inf

    def _position_command(self, torque: bool, vlim: float) -> Command:
        vscale = self._scale("v")
        prof_a = self._r.get("profile_acceleration")
        amax = self._profile_acceleration()
        if self._r.has("profile_velocity"):
            pv = self._r.get("profile_velocity")
        else:  # old PRO: Goal Velocity caps the position move
            pv = abs(self._r.get("goal_velocity"))
        vmax = min(pv * vscale, vlim) if pv > 0 else vlim
        if self._r.get("drive_mode") & 0x04 and pv > 0:  # time-based profile: ms, not velocity
            span = abs(self._r.get("goal_position") - self._user_position())
            accel_ms = min(prof_a, pv // 2) if prof_a > 0 else 0
            vmax = min(span / max((pv - accel_ms) / 1000.0, 1e-3), vlim) or vlim
            amax = vmax / (accel_ms / 1000.0) if accel_ms > 0 else math.inf
        target = (self._r.get("goal_position") - self._r.get("homing_offset")) * self._sign()
        return Command(torque, 0.0, target, vmax, amax, loop=self._servo_loop(vlim))

    def _servo_loop(self, vlim: float) -> ServoLoop | None:
        """The position loop from the gains, as multiples of the model's factory Position P Gain
        (None where the model has no such gain or factory value: the shaft is on the profile)."""
        factory_p = self._r.model.factory.get("position_p_gain", 0)
        if factory_p <= 0 or not self._r.has("position_p_gain"):
            return None
        full = self._pwm_full_scale()
        u_max = self._r.get("pwm_limit", full) / full if self._r.has("pwm_limit") else 1.0
        return ServoLoop.from_gains(self._r.get("position_p_gain") / factory_p,
                                    self._r.get("position_i_gain") / factory_p,
                                    self._r.get("position_d_gain") / factory_p, vlim, u_max)

    # ------------------------------------------------------------------ time
    def _watchdog_deadline(self) -> float | None:
        wd = self._r.get("bus_watchdog")
        if self._r.get("torque_enable") != 1 or not 1 <= wd <= 127:
            return None
        return self.last_instruction + wd * 0.020

    def refresh(self, now: float) -> None:
        """Advance motion to ``now`` and rewrite every present-value register."""
        deadline = self._watchdog_deadline()
        if deadline is not None and deadline < now:
            self.motor.advance(deadline - self._t, self.command())
            self._t = max(self._t, deadline)
            self._trip_watchdog()
        self.motor.advance(now - self._t, self.command())
        self._t = max(self._t, now)
        self._publish(now)

    def _trip_watchdog(self) -> None:
        """The e-Manual: the servo stops and Bus Watchdog reads -1; goals become read-only."""
        self.motor.stop()
        for goal in ("goal_velocity", "goal_pwm", "goal_current"):
            self._r.poke(goal, 0)
        self.hold_if_position_mode()
        self._r.poke("bus_watchdog", -1)
        codes = self._r.model.family.error_codes
        if codes is not None and codes.watchdog is not None:  # Y: Error Code 18 as well
            self._r.poke(codes.item, codes.watchdog)

    # ------------------------------------------------------------------ present values
    def _publish(self, now: float) -> None:
        torque = self._r.get("torque_enable") == 1
        cmd = self.command()
        self._publish_motion()
        self._publish_effort(torque)
        volts = self._r.model.item_scales.get("present_input_voltage", self._r.model.voltage_v_per_pulse)
        self._r.poke("present_input_voltage", int(round(self.supply_v / volts)))
        self._r.poke("realtime_tick", int((now - self._boot) * 1000) % 32768)
        self._publish_moving(torque, cmd)
        self._publish_ports()
        for name, value in self.pinned.items():
            self._r.poke(name, value)

    def _publish_motion(self) -> None:
        position = self._user_position()
        self._r.poke("present_position", int(round(position)))
        velocity = self._sign() * self.motor.v / self._scale("v")
        self._r.poke("present_velocity", int(round(velocity)))
        ref_p, ref_v = self.motor.reference()  # the profile's, during a move
        self._r.poke("position_trajectory", int(round(self._sign() * ref_p + self._r.get("homing_offset"))))
        self._r.poke("velocity_trajectory", int(round(self._sign() * ref_v / self._scale("v"))))

    def _publish_effort(self, torque: bool) -> None:
        """Current (or load), PWM and the temperature the current heats the servo to."""
        m, s = self.motor, self._sign()
        vlim = self._velocity_limit()
        mode = self._mode()
        frac_v = s * m.v / vlim
        frac_a = max(-1.0, min(1.0, s * m.a / (10.0 * vlim)))
        load = (0.05 * frac_v + 0.3 * frac_a) if torque else 0.0
        limit = self._r.get("current_limit", 0)
        current = self._r.get("goal_current") if (mode == "current" and torque) else int(round(load * limit))
        self._r.poke("present_current", current)
        self._r.poke("present_load", int(round(load * 1000)))
        full = self._pwm_full_scale()
        if not torque:
            pwm = 0
        elif mode == "pwm":
            pwm = self._r.get("goal_pwm")
        else:
            pwm = int(round((frac_v + 0.1 * frac_a) * full))
        pwm_limit = self._r.get("pwm_limit", full)
        self._r.poke("present_pwm", max(-pwm_limit, min(pwm_limit, pwm)))
        heat = abs(current) / limit if limit else 0.0
        self._r.poke("present_temperature", self.ambient_c + (2 if torque else 0) + int(round(8 * heat)))

    def _publish_moving(self, torque: bool, cmd: Command) -> None:
        in_motion = abs(self.motor.v) > self.threshold_pulses()
        ongoing = torque and cmd.target_p is not None and not self.motor.at_target(cmd)
        self._r.poke("moving", 1 if (in_motion or ongoing) else 0)
        status = 0
        if cmd.target_p is not None and torque:
            status = (0x02 | self._profile_kind << 4) if ongoing else 0x01
        self._r.poke("moving_status", status)

    def _publish_ports(self) -> None:
        for port in self._r.model.external_ports:
            mode = self._r.get(f"external_port_mode_{port}")
            value = {0: _ANALOG_INPUT, 1: self.port_latch.get(port, 0), 2: 1, 3: 0}.get(mode, 0)
            self._r.poke(f"external_port_data_{port}", value)
