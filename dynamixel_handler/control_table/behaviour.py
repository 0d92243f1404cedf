"""How a servo family behaves where families differ: one object per family (``ServoFamily.behaviour``).

The handler asks it, never the family's name or protocol: how the family's error state is read
and decoded into the X layout of hardware error bits, whether an error value is an error and how
it reads in words, what torque the error cut, how an error is cleared (a reboot, the Clear
instruction with its key, or an item written again), how its mode is selected (the Operating
Mode register, or the Angle Limits) and where the speed of a move goes (which message field, which
item, what 0 means). ``FamilyBehaviour`` is the X, P and PRO behaviour; the
others change what differs:

- ``ErrorCodeBehaviour`` (Y): one error code instead of the bits (``_error_codes``), cleared by
  the Clear instruction with its key;
- ``MovingSpeedBehaviour`` (XL-320): the speed of a move is Moving Speed, the velocity goal
  outside the position modes, where 0 means "as fast as the motor goes";
- ``Protocol1Behaviour`` (AX, RX, DX, EX, MX 1.0): that speed too, its mode selected by the Angle
  Limits (``mode_select``: no Operating Mode register), and the error state in the error byte of
  every status (no Hardware Error Status item); an overload or overheating is cleared by writing
  Torque Limit again (the e-Manual's way: the shutdown set it to 0), not by a reboot.

A new family is its data (``ServoFamily``) and one of these, or one more subclass (here, or in the
module of a family plug-in, ``_plugins.FamilyPlugin``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Protocol, Tuple, Union

from ..protocol import protocol1
from ._error_codes import ErrorCodes
from ._modes import POSITION_MODES
from ._protocol1 import TORQUE_CONTROL_ITEM, LimitModes

#: the item that holds the X, P and PRO error state
HARDWARE_ERROR = "hardware_error_status"
#: a mode asked for only when the answer needs it (it may take a read)
ModeNow = Callable[[], Optional[str]]
#: the X layout of the Hardware Error Status bits (e-Manual "Hardware Error Status(70)"), the one the
#: handler decodes (``units.decode_hardware_error``)
X_BITS = {"input_voltage": 0, "motor_hall_sensor": 1, "overheating": 2, "motor_encoder": 3,
          "electrical_shock": 4, "overload": 5}
#: hardware error bits in a layout: (cause, bit) pairs, causes as ``units.encode_shutdown`` names them
BitLayout = Tuple[Tuple[str, int], ...]


class HasItems(Protocol):
    """A model, as far as a behaviour asks it: which items its control table has, its position range."""

    @property
    def position_max_pulse(self) -> int: ...

    def has(self, name: str) -> bool: ...


@dataclass(frozen=True)
class ByReboot:
    """An error cleared by a reboot (the Hardware Error Status bits go with it)."""


@dataclass(frozen=True)
class ByClearInstruction:
    """An error cleared by the Clear instruction with these parameters (Y: 0x02 and the key "ERCL")."""

    params: bytes


@dataclass(frozen=True)
class ByWritingAgain:
    """An error cleared by writing ``item`` again with the value of ``source`` (Protocol 1.0: Torque
    Limit from Max Torque). ``item`` at 0 is an output the shutdown cut: cleared even when the
    status no longer shows the error (it shows the conditions of the moment)."""

    item: str
    source: str


Clearing = Union[ByReboot, ByClearInstruction, ByWritingAgain]


class FamilyBehaviour:
    """X, P and PRO: Hardware Error Status bits (in ``error_bits``' order where it is not the X one),
    cleared by a reboot; the speed of a move in position modes in message field ``speed_field``, to
    Profile Velocity where the model has it, else to ``move_speed_item``."""

    #: the codes of a family that reports one error code (None: bits)
    error_codes: Optional[ErrorCodes] = None
    #: the item the servo reports in the error byte of its status, not in a register (None: none)
    status_error_item: Optional[str] = None

    def __init__(self, speed_field: str = "profile_vel_deg_s", speed_item: str = "profile_velocity",
                 error_bits: BitLayout = ()) -> None:
        #: in position modes, the message field that gives the speed of a move
        self.speed_field = speed_field
        #: the item it goes to on a model without Profile Velocity
        self.move_speed_item = speed_item
        #: Hardware Error Status / Shutdown bits where they differ from the X and P layout; (): that layout
        self.error_bits = error_bits

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    # ------------------------------------------------------------ the error state
    @property
    def error_item(self) -> str:
        """The item that holds the error state (in the servo table too)."""
        return HARDWARE_ERROR

    def status_state(self, error_byte: int) -> int:
        """The bits of a status error byte that are the servo's state (``status_error_item``)."""
        return error_byte

    def common_bits(self, bits: int) -> int:
        """Hardware Error Status (or Shutdown) bits in the X and P layout the handler decodes."""
        if not self.error_bits or not bits:
            return bits
        return sum(1 << X_BITS[name] for name, bit in self.error_bits if bits >> bit & 1)

    def own_bits(self, common: int) -> int:
        """``common_bits`` the other way: bits of the X and P layout as the servo's register holds them."""
        if not self.error_bits:
            return common
        return sum(1 << bit for name, bit in self.error_bits if common >> X_BITS[name] & 1)

    def hardware_bits(self, value: int) -> int:
        """The hardware error bits (X layout) a value of ``error_item`` stands for."""
        return self.common_bits(value)

    def is_error(self, value: Optional[int]) -> bool:
        """A value of ``error_item`` is an error (bits set; an error code other than a warning)."""
        return bool(value)

    def describe(self, value: int) -> str:
        """A value of ``error_item`` in words ("0x24")."""
        return f"0x{value:02X}"

    def torque_cut(self, error: int, shutdown: Optional[int] = None) -> bool:
        """Whether the error switched torque off (then clearing it brings torque back): a bit the
        Shutdown item (``shutdown``; None: unknown, every bit) lists."""
        return bool(error & (0xFF if shutdown is None else shutdown))

    @property
    def clearing(self) -> Clearing:
        """How an error is cleared on command (``clear_error``)."""
        return ByReboot()

    # ------------------------------------------------------------ the mode
    def mode_select(self, model: HasItems) -> Optional[LimitModes]:
        """How ``model``'s mode is read and set where no Operating Mode register holds it; None: that
        register (``Model.mode_select`` asks this once per model)."""
        return None

    # ------------------------------------------------------------ the speed of a move
    def speed_item(self, model: HasItems) -> str:
        """The item the speed of a move in position modes goes to on ``model``."""
        return "profile_velocity" if model.has("profile_velocity") else self.move_speed_item

    def speed_in_position_only(self, model: HasItems) -> bool:
        """The speed of a move is set in position modes only: on ``model`` it is Moving Speed, the
        velocity goal in the other modes (written there, it would turn the shaft)."""
        return False

    def speed_pulses(self, pulses: int, mode: ModeNow) -> int:
        """A velocity goal of ``pulses`` as written in the servo's mode (``mode()``, asked only when
        it matters): unchanged, but where 0 means "as fast as the motor goes"."""
        return pulses

    def control_speed_item(self, model: HasItems, field: str, mode: str) -> Optional[str]:
        """The item a control topic's ``field`` goes to on ``model`` when it is the speed of a move
        (``speed_field`` in a position mode); None: it is not."""
        return self.speed_item(model) if field == self.speed_field and mode in POSITION_MODES else None

    @property
    def speed_item_is_per_model(self) -> bool:
        """The speed field of a move maps to an item that depends on the model (not the field's own
        goal item: the old PRO's velocity_deg_s in position control)."""
        return self.speed_field == "velocity_deg_s"

    def speed_per_model(self, field: str, mode: Optional[str]) -> bool:
        """``field`` of a control topic in ``mode`` is a speed of a move whose item depends on each
        servo's model."""
        return self.speed_item_is_per_model and field == self.speed_field and mode in POSITION_MODES


class ErrorCodeBehaviour(FamilyBehaviour):
    """Y: one error code (``codes``) instead of Hardware Error Status bits; an error it names as
    clearable is cleared by the Clear instruction with the family's key (a reboot if it has none)."""

    def __init__(self, codes: ErrorCodes, speed_field: str = "profile_vel_deg_s",
                 speed_item: str = "profile_velocity") -> None:
        super().__init__(speed_field, speed_item)
        self.error_codes: ErrorCodes = codes

    @property
    def error_item(self) -> str:
        return self.error_codes.item

    def hardware_bits(self, value: int) -> int:
        return self.error_codes.bits(value)

    def is_error(self, value: Optional[int]) -> bool:
        return bool(value) and self.error_codes.is_error(value or 0)

    def describe(self, value: int) -> str:
        """"error code 5 (Overload Error)"."""
        return f"error code {value} ({self.error_codes.name(value)})"

    def torque_cut(self, error: int, shutdown: Optional[int] = None) -> bool:
        """A code that switches torque off (an unknown code counts as one)."""
        code = self.error_codes.code(error)
        return code is None or code.torque_off

    @property
    def clearing(self) -> Clearing:
        params = self.error_codes.clear_params
        return ByClearInstruction(params) if params is not None else ByReboot()


class MovingSpeedBehaviour(FamilyBehaviour):
    """XL-320: on a model without Profile Velocity the speed of a move is Moving Speed, which is
    the velocity goal outside the position modes; in them 0 means "as fast as the motor goes", so
    a speed of 0 is written as the slowest the servo takes (1)."""

    def speed_in_position_only(self, model: HasItems) -> bool:
        return not model.has("profile_velocity")

    def speed_pulses(self, pulses: int, mode: ModeNow) -> int:
        return 1 if pulses == 0 and mode() in POSITION_MODES else pulses


class Protocol1Behaviour(MovingSpeedBehaviour):
    """Protocol 1.0: Moving Speed as the XL-320's, and the error state in the error byte of every
    status: its input voltage, overheating and overload bits (``error_bits``) are the servo's
    state, kept as its ``hardware_error_status``; angle limit, range, checksum and instruction are
    an instruction's fault. An error is cleared by writing Torque Limit again (to Max Torque, its
    power-on value), once the cause is gone."""

    status_error_item: Optional[str] = HARDWARE_ERROR

    def mode_select(self, model: HasItems) -> Optional[LimitModes]:
        """The Angle Limits select the mode (no Operating Mode register), and Torque Control Mode
        Enable where the model has it (MX-64/106)."""
        return LimitModes(model.position_max_pulse, model.has(TORQUE_CONTROL_ITEM))

    def status_state(self, error_byte: int) -> int:
        return error_byte & sum(1 << bit for _, bit in self.error_bits)

    def describe(self, value: int) -> str:
        """"overload error (0x20)"."""
        return protocol1.error_text(value)

    def torque_cut(self, error: int, shutdown: Optional[int] = None) -> bool:
        """Any error it reports (the Shutdown bits cut the output through Torque Limit)."""
        return bool(error)

    @property
    def clearing(self) -> Clearing:
        return ByWritingAgain("torque_limit", "pwm_limit")
