"""A virtual servo's shaft against what its registers read: the mode the registers select and the
frame between the shaft's raw pulses and Present / Goal Position.

The mode is the Operating Mode register, or, where the model has none (Protocol 1.0), what its Angle
Limits select (``Model.mode_select``: Wheel Mode with both 0, multi-turn with both 4095 on MX, current
control with Torque Control Mode Enable on MX-64/106); a mode the model lacks is Joint Mode there (a
DX with both Angle Limits 0). The frame: Drive Mode's reverse bit and Homing Offset where the firmware
has them; in multi-turn mode Resolution Divider and Multi Turn Offset (MX 1.0: Present Position =
turns of the shaft / Resolution Divider + Multi Turn Offset); on a firmware whose position is a
sensor's range (``Firmware.sensor_range``), Wheel Mode wraps over a turn and the shaft stays within
the range otherwise.
"""
from __future__ import annotations

from .firmware import Firmware
from .registers import Registers

#: modes whose goal is a position (by name: the Operating Mode values are the model's own)
POSITION_MODES = ("position", "ex_position", "cur_position")


class Frame:
    """The mode and the frames of one servo's registers (see the module)."""

    def __init__(self, registers: Registers, firmware: Firmware) -> None:
        self._r = registers
        self._fw = firmware
        self._top = registers.model.position_max_pulse

    def mode(self) -> str | None:
        """The operating mode by name (None: a register value the model does not know)."""
        r = self._r
        select = r.model.mode_select
        if select is None:
            return r.model.mode_name(r.get("operating_mode"))
        return r.model.mode_name(select.code({name: r.get(name) for name in select.items})) or "position"

    def sign(self) -> float:
        return -1.0 if self._fw.drive_mode_bits and self._r.get("drive_mode") & 0x01 else 1.0

    def _multi_turn(self, mode: str | None) -> tuple[int, int]:
        """(divider, offset) of multi-turn mode ((1, 0) in any other)."""
        if mode != "ex_position":
            return 1, 0
        return max(1, self._r.get("resolution_divider", 1)), self._r.get("multi_turn_offset")

    def user_position(self, raw: float) -> float:
        """Present Position of the shaft at ``raw`` pulses, in the present mode."""
        mode = self.mode()
        if self._fw.sensor_range and mode == "velocity":
            return raw % self.revolution()
        divider, offset = self._multi_turn(mode)
        return self.sign() * raw / divider + self._r.get("homing_offset") + offset

    def raw_position(self, user: float, by_hand: bool = False) -> float:
        """The shaft's raw pulses where Present Position (or Goal Position) reads ``user``;
        ``by_hand``: where a hand can turn it (on a sensor's range, within it but in multi-turn)."""
        mode = self.mode()
        divider, offset = self._multi_turn(mode)
        raw = (user - self._r.get("homing_offset") - offset) * divider * self.sign()
        if by_hand and self._fw.sensor_range and mode != "ex_position":
            return min(max(raw, 0.0), float(self._top))
        return raw

    def revolution(self) -> int:
        """Raw pulses a turn of the shaft spans."""
        if self._r.x:
            return 4096
        model = self._r.model
        if model.position_min_pulse >= 0:  # 0..1023 over 300 deg (XL-320, AX): the rest of a turn unseen
            return int(round(360.0 / model.position_deg_per_pulse))
        return 2 * model.position_max_pulse

    def fold(self, raw: float) -> float:
        """The shaft within one turn (and, on a sensor's range, within the range)."""
        rev = self.revolution()
        if self._r.x or self._r.model.position_min_pulse >= 0:
            folded = raw % rev
            return min(folded, float(self._top)) if self._fw.sensor_range else folded
        half = rev // 2
        return ((raw + half) % rev) - half

    def held(self, raw: float) -> float:
        """The shaft as the mode holds it: within the sensor's range in Joint Mode."""
        if self._fw.sensor_range and self.mode() == "position":
            return min(max(raw, 0.0), float(self._top))
        return raw
