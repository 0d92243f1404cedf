"""The shaft of a Protocol 1.0 virtual servo and the present values it writes.

A Protocol 1.0 servo has no Operating Mode register: its Angle Limits choose the mode
(``control_table._protocol1.mode_of``). The motor model is the one the Protocol 2.0 servos use
(``motion.Motor``); what differs is how the registers drive it (ROBOTIS e-Manual, AX-12A, MX-28 and
MX-64 pages):

* Joint Mode: the shaft moves to Goal Position at Moving Speed (0: as fast as the motor goes, taken
  as 1023 units, the no-load speed), accelerating at Goal Acceleration on MX (0: at once).
* Wheel Mode (both Angle Limits 0): Moving Speed is the speed and bit 10 its direction (set: CW,
  negative); the position wraps over the sensor's range.
* Multi-turn (MX, both Angle Limits 4095): Present Position = turns of the shaft / Resolution
  Divider + Multi Turn Offset, within -28,672..28,672; Goal Position the same way.
* Torque Control Mode (MX-64/106): Goal Torque (4.5 mA a unit, bit 10 the direction) drives the
  shaft like a current goal; Current reads 2048 + the current.
* Torque Limit 0 (what an Alarm Shutdown writes) leaves no output: the shaft stops.
* Present Speed, Present Load (0.1 % of the output) and Current follow the shaft; Present Voltage
  the supply (``supply_v``), Present Temperature the surroundings (``ambient_c``) and the load.
"""

from __future__ import annotations

import math

from dynamixel_handler.control_table._protocol1 import MULTI_TURN_GOAL, mode_of

from .motion import Command, Motor
from .registers import Registers

LAG_S = 0.05
FULL = 1023


class Shaft1:
    """The motor behind a Protocol 1.0 servo's registers, advanced lazily to the time asked."""

    def __init__(self, registers: Registers, now: float) -> None:
        self._r = registers
        self.motor = Motor()
        self._t = now
        self._boot = now
        self.supply_v = 12.0
        self.ambient_c = 30
        #: a load on the horn, as a share of the servo's full output (-1..1; beyond the Torque
        #: Limit's share it overloads the servo)
        self.external_load = 0.0
        #: present-value items held at a value (name -> value)
        self.pinned: dict[str, int] = {}
        model = registers.model
        self._top = model.position_max_pulse
        #: pulses a turn of the shaft spans (MX 4096; AX's 1023 over 300 deg: 1228, the rest unseen)
        self._rev = int(round(360.0 / model.position_deg_per_pulse))
        self._v_unit = model.velocity_deg_s_per_pulse / model.position_deg_per_pulse  # pulses/s per unit

    # ------------------------------------------------------------------ modes and frames
    def mode(self) -> str:
        """The mode the registers select, where the model has it; else Joint Mode (a DX with both
        Angle Limits 0, an EX-106+ with both at 4095: no Wheel Mode, no multi-turn there)."""
        r = self._r
        mode = mode_of(r.get("min_position_limit"), r.get("max_position_limit"), r.get("torque_control_mode_enable"))
        return mode if mode in r.model.mode_values else "position"

    def _divider(self) -> int:
        return max(1, self._r.get("resolution_divider", 1))

    def user_position(self) -> float:
        """The shaft as Present Position reads it in the present mode."""
        p = self.motor.p
        if self.mode() == "ex_position":
            return p / self._divider() + self._r.get("multi_turn_offset")
        return p % self._rev if self.mode() == "velocity" else p

    def fold(self) -> None:
        """The shaft within one turn and the sensor's range (a power cycle, or back to Joint Mode)."""
        self.motor.p = min(self.motor.p % self._rev, float(self._top))

    def power_up(self, now: float) -> None:
        """A power cycle: the shaft stops where it is (within one turn), the clock restarts."""
        self.motor.stop()
        self.fold()
        self._t = self._boot = now

    # ------------------------------------------------------------------ command
    def _output(self) -> bool:
        return self._r.get("torque_enable") == 1 and self._r.get("torque_limit") > 0

    def command(self) -> Command:
        if not self._output():
            return Command(False)
        mode, r = self.mode(), self._r
        top_speed = FULL * self._v_unit
        speed = r.get("goal_velocity")
        if mode == "velocity":
            return Command(True, speed * self._v_unit, None, top_speed, self._acceleration())
        if mode == "current":
            share = r.get("goal_current") / max(r.get("torque_limit"), 1)
            return Command(True, max(-1.0, min(1.0, share)) * top_speed, None, top_speed, math.inf, LAG_S)
        vmax = abs(speed) * self._v_unit if speed else top_speed
        return Command(True, 0.0, self._target(mode), vmax, self._acceleration())

    def _target(self, mode: str) -> float:
        goal = self._r.get("goal_position")
        if mode == "ex_position":
            return (goal - self._r.get("multi_turn_offset")) * self._divider()
        return float(goal)

    def _acceleration(self) -> float:
        accel = self._r.get("profile_acceleration", 0)
        if accel <= 0:
            return math.inf
        return accel * self._r.model.acceleration_deg_ss_per_pulse / self._r.model.position_deg_per_pulse

    def turn_to(self, present: float) -> None:
        """A hand turns the shaft until Present Position reads ``present`` [pulses] (in Joint Mode
        within the sensor's range; no instruction)."""
        self.motor.stop()
        if self.mode() == "ex_position":
            self.motor.p = (present - self._r.get("multi_turn_offset")) * self._divider()
        else:
            self.motor.p = min(max(present, 0.0), float(self._top))

    def hold(self) -> None:
        """Goal Position := Present Position (what the servo does at power on)."""
        self._r.poke("goal_position", int(round(self.user_position())))

    # ------------------------------------------------------------------ time
    def refresh(self, now: float) -> None:
        """Advance the shaft to ``now`` and rewrite the present values."""
        if now > self._t:
            self.motor.advance(now - self._t, self.command())
            self._t = now
        if self.mode() == "position":  # the sensor's range: the horn cannot go past its ends
            self.motor.p = min(max(self.motor.p, 0.0), float(self._top))
        self._publish(now)

    def load_share(self) -> float:
        """The output the shaft needs, as a share of the servo's full output (signed, CCW positive)."""
        if not self._output():
            return 0.0
        m = self.motor
        top = FULL * self._v_unit
        return self.external_load + 0.05 * m.v / top + max(-0.3, min(0.3, 0.3 * m.a / (10.0 * top)))

    def _publish(self, now: float) -> None:
        r = self._r
        position = self.user_position()
        if self.mode() == "ex_position":
            position = max(-MULTI_TURN_GOAL, min(MULTI_TURN_GOAL, position))
        r.poke("present_position", int(round(position)))
        r.poke("present_velocity", max(-FULL, min(FULL, int(round(self.motor.v / self._v_unit)))))
        share = self.load_share()
        r.poke("present_load", max(-FULL, min(FULL, int(round(share * FULL)))))
        self._publish_current(share)
        r.poke("present_input_voltage", int(round(self.supply_v * 10)))
        r.poke("present_temperature", self.ambient_c + (2 if self._output() else 0) + int(round(8 * abs(share))))
        r.poke("realtime_tick", int((now - self._boot) * 1000) % 32768)
        cmd = self.command()
        moving = abs(self.motor.v) > 0.5 * self._v_unit or (cmd.torque and cmd.target_p is not None
                                                             and not self.motor.at_target(cmd))
        r.poke("moving", 1 if moving else 0)
        for name, value in self.pinned.items():
            r.poke(name, value)

    def _publish_current(self, share: float) -> None:
        model = self._r.model
        if not model.has("present_current"):
            return
        zero = model.item_zero.get("present_current", 0)
        if self._output() and self.mode() == "current":
            ma = self._r.get("goal_current") * 4.5
        else:
            ma = share * 2000.0  # a representative full-output current
        self._r.poke("present_current", zero + int(round(ma / model.current_ma_per_pulse)))
