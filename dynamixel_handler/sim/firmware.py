"""What a virtual servo's firmware does beyond its control table, as data: one ``Firmware`` value per
protocol family, taken by the family's protocol (``firmware_of(model)``, as ``protocol.framers``
gives a framer per protocol). The one register engine (``servo.VirtualServo``) and the one motion
model (``dynamics.Dynamics``) read these fields; nothing in them asks which protocol a servo speaks.

Protocol 2.0 firmware (X, P, PRO, Y, XL-320; the e-Manual's "Protocol 2.0" and control-table pages):
a write is checked item by item (``write_rules``), errors are Hardware Error Status bits or a Y error
code (``error_state.RegisterErrors``), Drive Mode reverses the shaft and makes a profile time-based,
the Position Gains close a loop behind the profile, Goal Position := Present Position at Torque
Enable.

Protocol 1.0 firmware (AX, RX, DX, EX, MX (1.0); the e-Manual's AX-12A, MX-28, MX-64 pages and
"Protocol 1.0"): a write is checked byte by byte (``byte_rules``), the conditions of the moment are
bits of every status (``error_state.StatusErrors``), Torque Limit 0 leaves no output, the position is
a sensor's range (Joint Mode stays within it, Wheel Mode wraps over a turn), Baud Rate value v runs
at 2,000,000 / (v + 1) bps and a host within 3 % of it is heard, Goal Position := Present Position at
power on, the shaft is on the profile.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Optional

from dynamixel_handler.control_table import Item, Model
from dynamixel_handler.control_table._protocol1 import OUTPUT_FULL_SCALE, actual_bps

from ..protocol import protocol1 as p1
from ..protocol import servo as p
from . import byte_rules, write_rules
from .error_state import ErrorState, RegisterErrors, StatusErrors

CheckWrite = Callable[..., "tuple[int, list[tuple[Item, int]]]"]


@dataclass(frozen=True)
class Firmware:
    """One protocol family's firmware (see the module)."""

    #: how a write is checked: (registers, address, data, latched) -> (error, [(item, value)])
    check_write: CheckWrite
    #: the servo's error state, made for each servo: (registers, dynamics) -> its ``ErrorState``
    errors: Callable[..., ErrorState]
    #: the line speed a Baud Rate value runs at (None: a value the model does not know)
    line_bps: Callable[[Model, int], Optional[float]]
    #: how far from that speed a host may be, as a share of the host's speed, and still be heard
    baud_tolerance: float
    #: the fewest bytes a Read may ask for
    min_read: int
    #: Goal Position := Present Position at power on (else: at Torque Enable, in position modes)
    hold_at_power_on: bool
    #: Drive Mode bit 0 reverses the shaft and bit 2 makes the profile time-based
    drive_mode_bits: bool
    #: in position modes a loop of the Position Gains follows the profile (``servo_loop``)
    servo_loop: bool
    #: the position is a sensor's range: Joint Mode stays within it, Wheel Mode wraps over a turn
    sensor_range: bool
    #: the item that bounds a current goal (the goal's share of it drives the shaft)
    current_limit_item: str
    #: an item whose 0 leaves no output, torque still on (None: Torque Enable alone)
    output_item: Optional[str]
    #: Present Load at the full output
    load_full_scale: int
    #: Moving reads 1 above this speed [Present Velocity units] where the model has no Moving Threshold
    moving_threshold: float
    #: a refusal's Protocol 1.0 status bit by the engine's error code (any other refusal: Range Error)
    protocol1_bits: Mapping[int, int]
    #: it answers a Protocol 1.0 Bulk Read where its family does (``ServoFamily.bulk_read``)
    bulk_read1: bool


    def baudrate(self, model: Model, value: int) -> Optional[int]:
        """The line speed (bps) of a Baud Rate value: the model's nominal rate for it, or the rate it
        runs at (None: a value the model does not know)."""
        nominal = model.baud_rates.get(value)
        if nominal is not None:
            return nominal
        actual = self.line_bps(model, value)
        return None if actual is None else round(actual)

    def hears(self, model: Model, value: int, line_bps: Optional[int]) -> bool:
        """Whether a servo at Baud Rate ``value`` decodes a host at ``line_bps`` (None: any speed):
        within the tolerance of the rate the value runs at."""
        if line_bps is None:
            return True
        actual = self.line_bps(model, value)
        return actual is not None and abs(line_bps - actual) <= self.baud_tolerance * line_bps


def _table_bps(model: Model, value: int) -> Optional[float]:
    rate = model.baud_rates.get(value)
    return None if rate is None else float(rate)


PROTOCOL2 = Firmware(
    check_write=write_rules.check_write, errors=RegisterErrors, line_bps=_table_bps, baud_tolerance=0.0,
    min_read=0, hold_at_power_on=False, drive_mode_bits=True, servo_loop=True, sensor_range=False,
    current_limit_item="current_limit", output_item=None, load_full_scale=1000, moving_threshold=0.0,
    protocol1_bits={p.ERR_INSTRUCTION: p1.ERR_INSTRUCTION}, bulk_read1=False,
)
PROTOCOL1 = Firmware(
    check_write=byte_rules.check_write, errors=StatusErrors, line_bps=lambda model, value: actual_bps(value),
    baud_tolerance=0.03, min_read=1, hold_at_power_on=True, drive_mode_bits=False, servo_loop=False,
    sensor_range=True, current_limit_item="torque_limit", output_item="torque_limit",
    load_full_scale=OUTPUT_FULL_SCALE, moving_threshold=0.5,
    protocol1_bits={p.ERR_INSTRUCTION: p1.ERR_INSTRUCTION, p.ERR_DATA_LIMIT: p1.ERR_ANGLE_LIMIT}, bulk_read1=True,
)
#: the firmware of each protocol's families
FIRMWARES: Mapping[int, Firmware] = {2: PROTOCOL2, 1: PROTOCOL1}


def firmware_of(model: Model) -> Firmware:
    """The firmware of the model's family."""
    return FIRMWARES[model.family.protocol]
