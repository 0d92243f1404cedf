"""What a virtual servo's registers say about its shaft, and what the shaft says back: the one motion
model of every servo, Protocol 2.0 and 1.0 alike.

``Dynamics`` turns the goal registers into a ``Command`` for the motor model (``motion``), advances
the motor to the time of a request (tripping the bus watchdog on the way when it expires) and has
``present`` write every present-value register. The mode and the frames come from ``frames.Frame``;
what a firmware does differently from another (a loop behind the profile, an output item, the item
that bounds a current goal) from its ``firmware.Firmware``. A Protocol 1.0 servo (ROBOTIS e-Manual,
AX-12A, MX-28 and MX-64 pages): Joint Mode moves to Goal Position at Moving Speed (0: as fast as the
motor goes, taken as 1023 units), accelerating at Goal Acceleration on MX (0: at once); Wheel Mode
turns at Moving Speed, bit 10 the direction; Torque Control Mode (MX-64/106) drives the shaft like a
current goal; Torque Limit 0 (what an Alarm Shutdown writes) leaves no output.
"""

from __future__ import annotations

import math

from . import present
from .firmware import Firmware, firmware_of
from .frames import POSITION_MODES, Frame
from .motion import Command, Motor, profile_kind
from .registers import Registers
from .servo_loop import ServoLoop

LAG_S = 0.05

__all__ = ["Dynamics", "POSITION_MODES", "LAG_S"]


class Dynamics:
    """The motor behind the registers: the shaft's state, the time it was advanced to, the bus
    watchdog's last instruction, the latched external port outputs, the pinned present values and
    what the surroundings give (supply, ambient temperature, a load on the horn)."""

    def __init__(self, registers: Registers, now: float, firmware: Firmware | None = None) -> None:
        self._r = registers
        self.firmware = firmware or firmware_of(registers.model)
        self.frame = Frame(registers, self.firmware)
        self.motor = Motor()
        self._t = now
        self._boot = now
        #: when the last instruction for this servo arrived (the bus watchdog counts from it)
        self.last_instruction = now
        self.profile_kind = 0
        #: external port outputs written (port -> value)
        self.port_latch: dict[int, int] = {}
        #: present-value items held at a value (name -> value)
        self.pinned: dict[str, int] = {}
        self.supply_v = 12.0
        self.ambient_c = 30
        #: a load on the horn, as a share of the servo's full output (-1..1; beyond a Protocol 1.0
        #: servo's Torque Limit share it overloads it)
        self.external_load = 0.0

    @property
    def registers(self) -> Registers:
        return self._r

    @property
    def boot(self) -> float:
        return self._boot

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
            self.profile_kind = profile_kind(cmd.target_p - self.motor.p, cmd.vmax, cmd.amax)

    # ------------------------------------------------------------------ frames
    def mode(self) -> str | None:
        return self.frame.mode()

    def user_position(self) -> float:
        return self.frame.user_position(self.motor.p)

    def fold(self, raw: float) -> float:
        return self.frame.fold(raw)

    def turn_to(self, present: float) -> None:
        """A hand turns the shaft until Present Position reads ``present`` [pulses] (no
        instruction; with torque on the servo drives back to its goal)."""
        self.motor.stop()
        self.motor.p = self.frame.raw_position(present, by_hand=True)

    def hold(self) -> None:
        """Goal Position := Present Position."""
        self._r.poke("goal_position", int(round(self.user_position())))

    def hold_if_position_mode(self) -> None:
        if self.mode() in POSITION_MODES:
            self.hold()

    def scale(self, kind: str) -> float:
        """Raw pulses per second ("v") or per second squared ("a") in one unit of the registers."""
        per = {"v": self._r.model.velocity_deg_s_per_pulse, "a": self._r.model.acceleration_deg_ss_per_pulse}[kind]
        return per / self._r.model.position_deg_per_pulse

    def threshold_pulses(self) -> float:
        threshold = self._r.get("moving_threshold") if self._r.has("moving_threshold") else self.firmware.moving_threshold
        return threshold * self.scale("v")

    def pwm_full_scale(self) -> int:
        return 885 if self._r.x else 2009

    def output(self) -> bool:
        """Torque is on and the output item (Protocol 1.0: Torque Limit) leaves some output."""
        item = self.firmware.output_item
        return self._r.get("torque_enable") == 1 and (item is None or self._r.get(item) > 0)

    def mode_written(self, before: str | None) -> None:
        """A write changed the mode from ``before``: into Joint (position) mode, the shaft is folded
        into one turn (and a sensor's range)."""
        mode = self.mode()
        if mode != before and mode == "position":
            self.motor.p = self.fold(self.motor.p)

    def torque_changed(self, old: int, value: int, now: float) -> None:
        """Torque on: the shaft holds where it is (position modes); off: it stops."""
        if value == 1 and old == 0:
            if self.mode() == "position":
                self.motor.p = self.fold(self.motor.p)
            if not self.firmware.hold_at_power_on:
                self.hold_if_position_mode()
            self.last_instruction = now
        elif value == 0:
            self.motor.stop()

    # ------------------------------------------------------------------ command
    def command(self) -> Command:
        torque = self.output()
        mode = self.mode()
        s = self.frame.sign()
        vlim = self.velocity_limit()
        if mode in POSITION_MODES:
            return self._position_command(torque, vlim)
        amax = self._profile_acceleration()
        if mode == "velocity":
            return Command(torque, s * self._r.get("goal_velocity") * self.scale("v"), None, vlim, amax)
        if mode == "pwm":
            full = float(self.pwm_full_scale())
            return Command(torque, s * self._r.get("goal_pwm") / full * vlim, None, vlim, math.inf, LAG_S)
        if mode == "current":
            share = self._r.get("goal_current") / max(self._r.get(self.firmware.current_limit_item), 1)
            return Command(torque, s * max(-1.0, min(1.0, share)) * vlim, None, vlim, math.inf, LAG_S)
        return Command(False)

    def velocity_limit(self) -> float:
        """The top speed in pulses/s: Velocity Limit, or where a model has none (XL-320, Protocol
        1.0) its goal velocity's top (1023: the no-load speed)."""
        if self._r.has("velocity_limit"):
            pulses = self._r.get("velocity_limit")
        else:
            goal = self._r.model.items.get("goal_velocity")
            pulses = goal.max_raw if goal is not None else 0
        return max(pulses, 1) * self.scale("v")

    def _profile_acceleration(self) -> float:
        prof_a = self._r.get("profile_acceleration")
        return prof_a * self.scale("a") if prof_a > 0 else math.inf

    def _position_command(self, torque: bool, vlim: float) -> Command:
        vscale = self.scale("v")
        prof_a = self._r.get("profile_acceleration")
        amax = self._profile_acceleration()
        if self._r.has("profile_velocity"):
            pv = self._r.get("profile_velocity")
        else:  # old PRO, Protocol 1.0: Goal Velocity (Moving Speed) caps the position move
            pv = abs(self._r.get("goal_velocity"))
        vmax = min(pv * vscale, vlim) if pv > 0 else vlim
        if self.firmware.drive_mode_bits and self._r.get("drive_mode") & 0x04 and pv > 0:  # time-based profile
            span = abs(self._r.get("goal_position") - self.user_position())
            accel_ms = min(prof_a, pv // 2) if prof_a > 0 else 0
            vmax = min(span / max((pv - accel_ms) / 1000.0, 1e-3), vlim) or vlim
            amax = vmax / (accel_ms / 1000.0) if accel_ms > 0 else math.inf
        target = self.frame.raw_position(self._r.get("goal_position"))
        return Command(torque, 0.0, target, vmax, amax, loop=self._servo_loop(vlim))

    def _servo_loop(self, vlim: float) -> ServoLoop | None:
        """The position loop from the gains, as multiples of the model's factory Position P Gain
        (None where the firmware has none, or the model no such gain or factory value: the shaft
        is on the profile)."""
        factory_p = self._r.model.factory.get("position_p_gain", 0)
        if not self.firmware.servo_loop or factory_p <= 0 or not self._r.has("position_p_gain"):
            return None
        full = self.pwm_full_scale()
        u_max = self._r.get("pwm_limit", full) / full if self._r.has("pwm_limit") else 1.0
        return ServoLoop.from_gains(self._r.get("position_p_gain") / factory_p,
                                    self._r.get("position_i_gain") / factory_p,
                                    self._r.get("position_d_gain") / factory_p, vlim, u_max)

    def load_share(self) -> float:
        """The output the shaft needs, as a share of the servo's full output (signed, CCW positive)."""
        if not self.output():
            return 0.0
        m, s = self.motor, self.frame.sign()
        vlim = self.velocity_limit()
        frac_v = s * m.v / vlim
        frac_a = max(-1.0, min(1.0, s * m.a / (10.0 * vlim)))
        return self.external_load + 0.05 * frac_v + 0.3 * frac_a

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
        self.motor.p = self.frame.held(self.motor.p)
        present.publish(self, now)

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
