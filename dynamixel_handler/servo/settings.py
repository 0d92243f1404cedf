"""Per-servo settings: the ``servos`` block of the parameters file, as typed values (ROS-free).

One entry per servo, named ``id_<N>`` or by a joint name of ``joint_state.names``; its items are
named like the fields of the command messages, in their units::

    servos:
      id_1: {mode: cur_position, position_p_gain_pulse: 640, velocity_limit_deg_s: 120.0}
      wrist: {position_p_gain_pulse: 700, drive_mode: {reverse_mode: true}}

In a ROS parameter file the block arrives flattened (``servos.id_1.position_p_gain_pulse``):
:func:`servo_block` reads those names; plain Python builds :class:`ServoSetting` values directly::

    Settings(servos=(ServoSetting(1, {"mode": "cur_position", "position_p_gain_pulse": 640}),))

A name or a value of the wrong type is a ConfigError naming servo, item and value. What depends on
the servo's model (an item it lacks, a value beyond its e-Manual range, a mode it lacks) is checked
once the scan has found it (``servo_targets.refusals``).
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Protocol, Sequence

from ..control_table import OPERATING_MODES
from ..errors import ConfigError
from ..logs import cut
from .groups import GAIN, LIMIT

#: the parameter names of the block start so
PREFIX = "servos."
#: the key of an entry that lets it lower a protection (not an item)
FORCE = "force"
#: the largest whole number an item takes (a register holds at most 4 bytes; a ROS integer 8)
_INT_MAX = 2**31

#: how an item is applied: the mode; an item of the servo's control table in message units
#: (EEPROM or RAM, as the model says); a gain in register units; bits of a bit-field register;
#: the LED; the bus watchdog (the handler's watchdog keeps it)
MODE, UNIT, PULSE, BITS, LED, WATCHDOG = "mode", "unit", "pulse", "bits", "led", "watchdog"


@dataclass(frozen=True)
class Field:
    """One item of a servo's entry: the control-table item, how it is applied, its value type."""

    item: str
    kind: str
    type: type
    meaning: str


def _unit(field: str) -> str:
    """The unit a message field's name ends with."""
    for suffix, unit in (("_deg_ss", "deg/s^2"), ("_deg_s", "deg/s"), ("_deg", "deg"), ("_degc", "degC"), ("_ma", "mA"),
                         ("_percent", "%"), ("_v", "V")):
        if field.endswith(suffix):
            return unit
    return "?"


_SHUTDOWN = ("overload_error", "electrical_shock_error", "motor_encoder_error", "motor_hall_sensor_error",
             "overheating_error", "input_voltage_error")

#: item of an entry (dotted for nested ones) -> what it is
FIELDS: Mapping[str, Field] = {
    "mode": Field("operating_mode", MODE, str, f"operating mode ({', '.join(OPERATING_MODES)})"),
    **{f: Field(i, PULSE, int, f"{i.replace('_', ' ')} [pulse] (DynamixelGain)") for i, f in GAIN.items()},
    **{f: Field(i, UNIT, float, f"{i.replace('_', ' ')} [{_unit(f)}] (DynamixelLimit)") for i, f in LIMIT.items()},
    "profile_vel_deg_s": Field("profile_velocity", UNIT, float, "profile velocity [deg/s] (DynamixelGoal)"),
    "profile_acc_deg_ss": Field("profile_acceleration", UNIT, float, "profile acceleration [deg/s^2] (DynamixelGoal)"),
    "homing_offset_deg": Field("homing_offset", UNIT, float, "homing offset [deg] (DynamixelExtra)"),
    "return_delay_time_us": Field("return_delay_time", UNIT, float, "return delay time [us] (DynamixelExtra)"),
    "drive_mode.reverse_mode": Field("drive_mode", BITS, bool, "drive mode: reverse (DynamixelExtra)"),
    "drive_mode.torque_on_by_goal_update": Field("drive_mode", BITS, bool,
                                                 "drive mode: torque on by goal update (DynamixelExtra)"),
    "drive_mode.profile_configuration": Field("drive_mode", BITS, str,
                                              "drive mode: velocity_based or time_based (DynamixelExtra)"),
    **{f"shutdown.{b}": Field("shutdown", BITS, bool, f"shutdown on {b.replace('_', ' ')} (DynamixelExtra)")
       for b in _SHUTDOWN},
    **{f"led.{c}_percent": Field("led", LED, float, f"{c} LED [%] (DynamixelExtra)") for c in ("red", "green", "blue")},
    "bus_watchdog_ms": Field("bus_watchdog", WATCHDOG, float, "bus watchdog [ms] (DynamixelExtra; 0: off)"),
}
PROFILE_CONFIGURATIONS = ("velocity_based", "time_based")


@dataclass(frozen=True)
class ServoSetting:
    """What the parameters file sets for one servo: ``values`` maps items of :data:`FIELDS` (nested
    ones dotted, or given as nested mappings) to values in the message units; ``name`` is the entry's
    name in the file (default ``id_<N>``). ConfigError for an unknown item or a value of the wrong
    type."""

    dxl_id: int
    values: Mapping[str, Any] = field(default_factory=dict)
    name: str = ""
    #: write values that lower a protection (Shutdown bits off, a temperature or voltage limit
    #: beyond its factory value, the turning direction reversed); in a file: ``force: true``
    force: bool = False

    def __post_init__(self) -> None:
        if not self.name:
            object.__setattr__(self, "name", f"id_{self.dxl_id}")
        if type(self.dxl_id) is not int or not 0 <= self.dxl_id <= 252:
            raise ConfigError(f"servos.{self.name}: servo ID {cut(self.dxl_id)} is not within 0..252")
        flat = dict(_flat(self.values))
        force = flat.pop(FORCE, self.force)
        if type(force) is not bool:
            raise ConfigError(f"servos.{self.name}.{FORCE} = {cut(repr(force))}: must be true or false (true: write "
                              "values that lower a protection)")
        object.__setattr__(self, "force", force)
        checked = tuple((item, _checked(self.name, item, value)) for item, value in flat.items())
        object.__setattr__(self, "values", _Frozen(checked))

    def sets(self, item: str) -> bool:
        """Whether the entry sets control-table ``item`` (by any of its fields)."""
        return any(FIELDS[f].item == item for f in self.values)


class _Frozen(dict[str, Any]):
    """A read-only dict that hashes (a frozen dataclass field)."""

    def __hash__(self) -> int:  # type: ignore[override]
        return hash(tuple(self.items()))

    def _refuse(self, *_: object, **__: object) -> None:
        raise TypeError("ServoSetting.values is read-only")

    __setitem__ = __delitem__ = update = pop = clear = setdefault = popitem = _refuse  # type: ignore[assignment]


def _flat(values: Mapping[str, Any], prefix: str = "") -> Iterable[tuple[str, Any]]:
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            yield from _flat(value, name + ".")
        else:
            yield name, value


def _checked(servo: str, item: str, value: Any) -> Any:
    """``value`` in the item's type (an int for a float; an integral float for an int)."""
    spec = FIELDS.get(item)
    where = f"servos.{servo}.{cut(item)}"
    if spec is None:
        hint = difflib.get_close_matches(item, FIELDS, n=1)
        raise ConfigError(f"{where} = {cut(value)}: unknown item" + (f": did you mean '{hint[0]}'?" if hint else
                          f" (known: {', '.join(FIELDS)})"))
    got = _typed(spec.type, value)
    if got is None and spec.type is int and isinstance(value, (int, float)) and not isinstance(value, bool) \
            and abs(value) >= _INT_MAX:
        raise ConfigError(f"{where} = {cut(repr(value))}: beyond any register (a whole number within "
                          f"-{_INT_MAX}..{_INT_MAX - 1}; {spec.meaning})")
    if got is None:
        raise ConfigError(f"{where} = {cut(repr(value))}: must be {spec.type.__name__} ({spec.meaning})")
    why = _wrong_value(item, spec, got)
    if why:
        raise ConfigError(f"{where} = {cut(got)}: {why}")
    return got


def _wrong_value(item: str, spec: Field, got: Any) -> str:
    """Why a value of the right type is refused whatever the model ("": it is not)."""
    if item == "mode" and got not in OPERATING_MODES:
        return f"unknown mode (known: {', '.join(OPERATING_MODES)})"
    if item == "drive_mode.profile_configuration" and got not in PROFILE_CONFIGURATIONS:
        return "must be velocity_based or time_based"
    if spec.type in (int, float) and got < 0 and spec.item not in _SIGNED:
        return "must not be negative"
    if spec.kind == LED and got > 100:
        return "must be within 0..100 %"
    return ""


#: items that may be negative
_SIGNED = ("max_position_limit", "min_position_limit", "homing_offset")


def _typed(kind: type, value: Any) -> Any:
    if kind is bool or kind is str:
        return value if type(value) is kind else None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    if kind is int:
        return int(value) if float(value).is_integer() and abs(value) < _INT_MAX else None
    return float(value)


class JointNames(Protocol):
    """What an entry's joint name is looked up in (``joints.JointMap``): the names and their servos."""

    @property
    def names(self) -> Sequence[str]: ...

    def id_of(self, name: str) -> int: ...


def servo_key(name: str, joints: JointNames | None) -> int:
    """The servo ID an entry's name stands for: ``id_<N>``, or a joint of ``joint_state.names``."""
    digits = name[3:]
    if name.startswith("id_") and digits.isascii() and digits.isdigit():  # not "id_²" nor "id_٢"
        return int(digits)
    if joints is not None and name in joints.names:
        try:
            return joints.id_of(name)
        except ValueError as err:  # a joint of several servos: which one?
            raise ConfigError(f"servos.{cut(name)}: {err}") from None
    known = f"the joints are {', '.join(joints.names)}" if joints is not None else "joint_state.names maps none"
    raise ConfigError(f"servos.{cut(name)}: neither id_<N> nor a joint name of joint_state.names ({known})")


def servo_settings(block: Mapping[str, Mapping[str, Any]], joints: JointNames | None = None) -> tuple[ServoSetting, ...]:
    """The entries of a ``servos`` block given as nested mappings ({name: {item: value}}), in ID
    order; ConfigError for an entry that is no mapping, an unknown name, a servo named twice."""
    out: dict[int, ServoSetting] = {}
    for name, values in block.items():
        if not isinstance(values, Mapping):
            raise ConfigError(f"servos.{cut(name)} = {cut(repr(values))}: must be a block of items, e.g. "
                              f"servos.{cut(name)}.position_p_gain_pulse")
        dxl_id = servo_key(name, joints)
        if dxl_id in out:
            raise ConfigError(f"servos.{cut(name)}: servo ID {dxl_id} is also given as servos.{out[dxl_id].name}: "
                              "give each servo once")
        out[dxl_id] = ServoSetting(dxl_id, values, name)
    return tuple(out[i] for i in sorted(out))


def servo_block(values: Mapping[str, Any], joints: JointNames | None = None) -> tuple[ServoSetting, ...]:
    """The entries given by flattened parameter names (``servos.<name>.<item>``) in ``values``."""
    block: dict[str, dict[str, Any]] = {}
    for name, value in values.items():
        if not (name.startswith(PREFIX) or name == PREFIX[:-1]):
            continue
        servo, _, item = name[len(PREFIX):].partition(".")
        if not servo or not item:
            raise ConfigError(f"parameter '{cut(name)}' = {cut(repr(value))}: the servos block holds one block "
                              "per servo, e.g. servos.id_1.position_p_gain_pulse")
        if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
            raise ConfigError(f"{cut(name)} = {cut(repr(list(value)))}: must be a single value, not a list")
        block.setdefault(servo, {})[item] = value
    return servo_settings(block, joints)


def is_servo_parameter(name: str) -> bool:
    return name.startswith(PREFIX) or name == PREFIX[:-1]


__all__ = ["FIELDS", "FORCE", "PREFIX", "Field", "ServoSetting", "is_servo_parameter", "servo_block", "servo_settings"]
