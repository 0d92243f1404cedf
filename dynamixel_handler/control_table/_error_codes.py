"""Servos that report one error code instead of Hardware Error Status bits (the Y series).

The handler's error state (``DynamixelError``, the ``error`` flag of ``DynamixelStatus``, the
health and the log) speaks in the X-style hardware error bits; a family with an error code says,
as data, which bits each code stands for, which codes are errors at all (a warning leaves the
servo running and is not cleared), which a Clear instruction can clear and the code's name.

Y series codes, from the ROBOTIS e-Manual ("Error Code(153)", the DYNAMIXEL-Y control table
pages, e.g. docs/en/dxl/y/ym080-230-a099-rh): 1 over voltage, 2 low voltage, 3 inverter
overheating, 4 motor overheating, 5 overload, 7 inverter error, 9 battery warning (torque stays
on), 10 battery error, 11 magnet error, 12 multi-turn error, 13 encoder error, 14 hall sensor
error, 15 calibration error, 17 following error, 18 bus watchdog error, 19 over speed error,
20 position limit reached error. Codes 1-5 and 17-20 are cleared by the Error Clear packet
(Clear instruction 0x10, P1 0x02, then 0x45 0x52 0x43 0x4C); 7 and 10-15 are not. Codes 1-15
but 9 switch torque off; 17-20 hold the servo with torque on (goal writes refused).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

# X Hardware Error Status bits (e-Manual "Hardware Error Status(70)")
INPUT_VOLTAGE, HALL_SENSOR, OVERHEATING, ENCODER, ELECTRICAL_SHOCK, OVERLOAD = (1 << b for b in (0, 1, 2, 3, 4, 5))


@dataclass(frozen=True)
class ErrorCode:
    """One code: its value, its name, the hardware error bits it stands for (0: none matches),
    whether it is a warning only, whether the Clear instruction clears it, whether it switches
    torque off (the others hold the servo: torque on, goal writes refused)."""

    value: int
    name: str
    bits: int
    warning: bool = False
    clearable: bool = True
    torque_off: bool = True

    @property
    def hold(self) -> bool:
        """An error that keeps torque on but holds the servo where it is (not a warning)."""
        return not self.torque_off and not self.warning


@dataclass(frozen=True)
class ErrorCodes:
    """The error code register of a family and what its values mean."""

    #: canonical item name of the register
    item: str
    codes: Tuple[ErrorCode, ...]
    #: parameters of the Clear instruction that clears an error (None: a reboot clears it)
    clear_params: Optional[bytes] = None
    #: the code a tripped bus watchdog sets (writing Bus Watchdog 0 clears it too); None: none
    watchdog: Optional[int] = None

    def code(self, value: int) -> Optional[ErrorCode]:
        """The code a register value holds; None for 0 (no error) and values the manual lacks."""
        return next((c for c in self.codes if c.value == value), None)

    def bits(self, value: int) -> int:
        """The hardware error bits a register value stands for."""
        code = self.code(value)
        return code.bits if code is not None else 0

    def is_error(self, value: int) -> bool:
        """A value other than 0 that is not a warning (an unknown code counts as an error)."""
        code = self.code(value)
        return value != 0 and (code is None or not code.warning)

    def name(self, value: int) -> str:
        """The code's name as the e-Manual gives it (unknown codes by number)."""
        code = self.code(value)
        return code.name if code is not None else ("no error" if value == 0 else f"error code {value}")


Y_ERROR_CODES = ErrorCodes(
    item="error_code",
    codes=(
        ErrorCode(1, "Over Voltage Error", INPUT_VOLTAGE),
        ErrorCode(2, "Low Voltage Error", INPUT_VOLTAGE),
        ErrorCode(3, "Inverter Overheating Error", OVERHEATING),
        ErrorCode(4, "Motor Overheating Error", OVERHEATING),
        ErrorCode(5, "Overload Error", OVERLOAD),
        ErrorCode(7, "Inverter Error", ELECTRICAL_SHOCK, clearable=False),
        ErrorCode(9, "Battery Warning", 0, warning=True, clearable=False, torque_off=False),
        ErrorCode(10, "Battery Error", ENCODER, clearable=False),
        ErrorCode(11, "Magnet Error", ENCODER, clearable=False),
        ErrorCode(12, "Multi-Turn Error", ENCODER, clearable=False),
        ErrorCode(13, "Encoder Error", ENCODER, clearable=False),
        ErrorCode(14, "Hall Sensor Error", HALL_SENSOR, clearable=False),
        ErrorCode(15, "Calibration Error", 0, clearable=False),
        ErrorCode(17, "Following Error", 0, torque_off=False),
        ErrorCode(18, "Bus Watchdog Error", 0, torque_off=False),
        ErrorCode(19, "Over Speed Error", 0, torque_off=False),
        ErrorCode(20, "Position Limit Reached Error", 0, torque_off=False),
    ),
    clear_params=bytes([0x02, 0x45, 0x52, 0x43, 0x4C]),
    watchdog=18,
)
