"""A servo family (series): what every model of it shares and the handler acts on, as data, and
how it behaves where families differ (``behaviour``, one ``FamilyBehaviour`` per family).

The X, P and PRO families differ in the modes their command topics offer, in how a goal is
bounded, in which item carries the speed of a move in position modes, and in how parameters and
messages spell them. Everything that depends on the family reads one of these attributes or asks
its behaviour; a new family (MX, XL-320, Y) is one more value here, with the behaviour it shares
with others or one of its own, not a new branch in the code; a family from outside the package is
such a value too, named by an installed plug-in (``_plugins.FamilyPlugin``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import FrozenSet, Mapping, Optional, Tuple

from ._error_codes import Y_ERROR_CODES, ErrorCodes
from .behaviour import ErrorCodeBehaviour, FamilyBehaviour, MovingSpeedBehaviour, Protocol1Behaviour

#: turns a goal may hold (rotation field; a goal of a family without a multi-turn goal range is
#: bounded to as many turns)
MAX_ROTATION = 256.0

_ALL_MODES = frozenset({"current", "velocity", "position", "ex_position", "cur_position", "pwm"})


@dataclass(frozen=True)
class ServoFamily:
    """One servo family. Compared by identity: every model of the family carries the same value."""

    #: the name the handler uses (``Model.series``, the ``series`` of commands and logs)
    name: str
    #: as parameters (``init/used_servo_series.<title>``) and DynamixelExtra.model spell it
    title: str
    #: of its topics (``commands/<suffix>``, ``command/<suffix>/...``) and messages
    suffix: str
    #: operating modes its control topics offer
    modes: FrozenSet[str]
    #: model number a dummy servo of the family has
    dummy_model: int
    #: the X-style control table: 4096 pulses per turn around 2048, PWM 885 full scale, the
    #: e-Manual's fixed register ranges (the simulator's write rules follow them)
    x_table: bool
    #: Profile Velocity / Profile Acceleration take 0..this (the register's own range, not
    #: bounded by Velocity / Acceleration Limit); None: bounded by those limits
    profile_max: Optional[int]
    #: multi-turn goal positions take ±this many pulses; None: ±``MAX_ROTATION`` turns, also in
    #: position mode when the position limits are not known
    multi_turn_goal: Optional[int]
    #: how it behaves where families differ: its error state and how it is cleared, where the speed
    #: of a move goes (``behaviour.py``)
    behaviour: FamilyBehaviour
    #: the family has a Protocol Type register (False: it speaks Protocol 2.0 only, reported as 2)
    has_protocol_type: bool = True
    #: ``init/used_servo_series.<title>`` when no parameter sets it (the original handler's defaults
    #: for X, P and Pro; a family added later is off, so an older parameter file keeps its meaning)
    used_by_default: bool = False
    #: the family has command topics of its own (``commands/<suffix>``, ``command/<suffix>/...``);
    #: False: it is driven through the series-independent topics only (Y)
    series_topics: bool = True
    #: the family whose command topics and messages drive this one (XL-320: the X ones, where an
    #: item exists); None: its own
    commanded_as: Optional["ServoFamily"] = None
    #: the Dynamixel protocol its servos speak (the framer a bus uses for them): 2, or 1 (AX, RX, DX,
    #: EX, MX with the Protocol 1.0 firmware)
    protocol: int = 2
    #: the servos answer a Bulk Read (every Protocol 2.0 servo; on Protocol 1.0 the MX and EX only)
    bulk_read: bool = True

    def __repr__(self) -> str:
        return f"ServoFamily({self.name})"

    @property
    def topics(self) -> "ServoFamily":
        """The family whose command topics and messages drive this one (itself, or ``commanded_as``)."""
        return self.commanded_as or self

    @property
    def command_family(self) -> Optional["ServoFamily"]:
        """The family whose series topics (``commands/<suffix>``, ``command/<suffix>/...``) drive this
        one: itself, the one it is commanded as (XL-320: X); None: the series-independent topics only."""
        return self.topics if self.topics.series_topics else None

    @property
    def move_speed_field(self) -> str:
        """In position modes, the message field that gives the speed of a move."""
        return self.behaviour.speed_field

    @property
    def move_speed_item(self) -> str:
        """The item the speed of a move goes to on a model without Profile Velocity."""
        return self.behaviour.move_speed_item

    @property
    def error_codes(self) -> Optional[ErrorCodes]:
        """The codes of a family that reports one error code instead of Hardware Error Status bits
        (None: the bits)."""
        return self.behaviour.error_codes

    @property
    def error_bits(self) -> Tuple[Tuple[str, int], ...]:
        """Hardware Error Status / Shutdown bits where they differ from the X and P layout: (cause,
        bit) pairs; (): that layout."""
        return self.behaviour.error_bits

    @property
    def speed_item_is_per_model(self) -> bool:
        """True when the speed field of a move maps to an item that depends on the model (not the
        field's own goal item)."""
        return self.behaviour.speed_item_is_per_model

    @property
    def protocol_note(self) -> str:
        """What a line about one of its servos adds to name the protocol ("": 2.0, the usual one)."""
        return ", Protocol 1.0" if self.protocol == 1 else ""

    def reads_fast(self, fast_read: bool) -> bool:
        """Whether its servos are read with the faster group read: Fast Sync Read (Protocol 2.0,
        ``method/fast_read``), Bulk Read (Protocol 1.0: where the model takes it, MX and EX)."""
        return fast_read if self.protocol == 2 else self.bulk_read

    def speed_item(self, has_profile_velocity: bool) -> str:
        """The item the speed of a move in position modes goes to, on a model with or without
        Profile Velocity."""
        return "profile_velocity" if has_profile_velocity else self.behaviour.move_speed_item

    def goal_position_bounds(self, lo: int, hi: int, deg_per_pulse: float) -> Tuple[int, int, int, int]:
        """The goal position bounds from the register range (lo, hi) and the model's scale: in
        position mode without valid position limits (lo, hi), then in any other mode (lo, hi)."""
        if self.multi_turn_goal is not None:
            return lo, hi, max(lo, -self.multi_turn_goal), min(hi, self.multi_turn_goal)
        turns = int(round(MAX_ROTATION * 360.0 / deg_per_pulse))
        return max(lo, -turns), min(hi, turns), max(lo, -turns), min(hi, turns)

    def profile_bounds(self, hi: int) -> Tuple[int, int]:
        """A profile item's bounds when no limit item bounds it (register top ``hi``)."""
        return 0, min(hi, self.profile_max) if self.profile_max is not None else hi


X = ServoFamily(
    name="X", title="X", suffix="x", modes=_ALL_MODES, dummy_model=1020, x_table=True,
    profile_max=32767,  # e-Manual: 0..32767 whatever the limits
    multi_turn_goal=1_048_575,  # e-Manual: -1,048,575..1,048,575 pulses (±256 turns)
    behaviour=FamilyBehaviour(), used_by_default=True,
)
P = ServoFamily(
    name="P", title="P", suffix="p", modes=_ALL_MODES - {"cur_position"}, dummy_model=2020, x_table=False,
    profile_max=None, multi_turn_goal=None, behaviour=FamilyBehaviour(),
)
PRO = ServoFamily(
    name="PRO", title="Pro", suffix="pro", modes=frozenset({"current", "velocity", "position", "ex_position"}),
    dummy_model=54024, x_table=False, profile_max=None, multi_turn_goal=None,
    # the old PRO has no Profile Velocity: its position control's velocity_deg_s is Goal Velocity
    behaviour=FamilyBehaviour("velocity_deg_s", "goal_velocity"), has_protocol_type=False,
)

# DYNAMIXEL-Y (e-Manual docs/en/dxl/y/...): current, velocity and position control only; Profile
# Velocity / Acceleration bounded by Velocity / Acceleration Limit; no command messages of its own.
Y = ServoFamily(
    name="Y", title="Y", suffix="y", modes=frozenset({"current", "velocity", "position"}),
    dummy_model=4170, x_table=False, profile_max=None, multi_turn_goal=None,
    behaviour=ErrorCodeBehaviour(Y_ERROR_CODES), series_topics=False,
)

# XL-320 (e-Manual docs/en/dxl/x/xl320): a small table of its own, Joint (position) and Wheel
# (velocity) mode only, Moving Speed as the speed of a move; driven through the X topics.
XL320 = ServoFamily(
    name="XL320", title="XL320", suffix="x", modes=frozenset({"velocity", "position"}),
    dummy_model=350, x_table=False, profile_max=None, multi_turn_goal=None,
    behaviour=MovingSpeedBehaviour(speed_item="goal_velocity",
                                   error_bits=(("overload", 0), ("overheating", 1), ("input_voltage", 2))),
    has_protocol_type=False, commanded_as=X,
)

# Protocol 1.0 families (``_protocol1``): no Operating Mode register (the Angle Limits select Joint,
# Wheel and, on MX, multi-turn mode), Moving Speed as the speed of a move, driven through the
# series-independent topics only. Status, Alarm LED and Shutdown bits: input voltage 0, angle limit 1,
# overheating 2, range 3, checksum 4, overload 5, instruction 6 (here the three the X layout also has).
_P1_BITS = (("input_voltage", 0), ("overheating", 2), ("overload", 5))


def _protocol1_family(title: str, modes: FrozenSet[str], dummy: int, bulk_read: bool,
                      multi_turn_goal: Optional[int] = None) -> ServoFamily:
    return ServoFamily(
        name=title, title=title, suffix=title.lower(), modes=modes, dummy_model=dummy, x_table=False,
        profile_max=None, multi_turn_goal=multi_turn_goal,
        behaviour=Protocol1Behaviour(speed_item="goal_velocity", error_bits=_P1_BITS), has_protocol_type=False,
        series_topics=False, protocol=1, bulk_read=bulk_read,
    )


_JOINT_WHEEL = frozenset({"position", "velocity"})
AX = _protocol1_family("AX", _JOINT_WHEEL, 12, bulk_read=False)
RX = _protocol1_family("RX", _JOINT_WHEEL, 28, bulk_read=False)
DX = _protocol1_family("DX", frozenset({"position"}), 117, bulk_read=False)  # no Wheel Mode
EX = _protocol1_family("EX", _JOINT_WHEEL, 107, bulk_read=True)
# MX (1.0): multi-turn on MX-28/64/106 (both Angle Limits 4095, goal -28,672..28,672), current
# (Torque Control Mode) on MX-64/106: each model lists its own modes
MX1 = _protocol1_family("MX1", frozenset({"position", "velocity", "ex_position", "current"}), 29,
                        bulk_read=True, multi_turn_goal=28_672)

#: the families this package defines, in the order parameters, topics and logs list them (``FAMILIES``
#: of ``control_table`` adds those of installed plug-ins, ``FamilyPlugin``)
BUILT_IN: Tuple[ServoFamily, ...] = (X, P, PRO, Y, XL320)
#: the Protocol 1.0 families this package defines (``PROTOCOL1_FAMILIES``: with the plug-ins' ones)
BUILT_IN_PROTOCOL1: Tuple[ServoFamily, ...] = (AX, RX, DX, EX, MX1)
#: a built-in family by its name, for the builders of its models
BUILT_IN_NAMED: Mapping[str, ServoFamily] = {f.name: f for f in BUILT_IN + BUILT_IN_PROTOCOL1}
