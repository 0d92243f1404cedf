"""Vectorised conversion between control-table pulses and the product's physical units.

One call converts one item for a whole bus at once, even when the servos are of different
models: the per-element scale, offset and representable range are looked up once per
(models, item) combination and cached, because the read/write loops run at 100 Hz and more.

Physical units: position, homing offset, position limits and trajectory in deg; velocity, profile
velocity, velocity limit and moving threshold in deg/s; profile acceleration and acceleration
limit in deg/s^2; current and current limit in mA; PWM and PWM limit in %; voltage in V;
temperature in degC; return delay in us; bus watchdog in ms; realtime tick in s; Present Load
(XL430 / XC430, which have no current sensor) in %. Gains, ids, modes and flags stay raw.

Caveat: when Drive Mode selects the time-based profile, the X/P firmware reads Profile Velocity
and Profile Acceleration as milliseconds; these functions always use the velocity-based units.
"""

from __future__ import annotations

import functools
import math
from typing import Dict, List, Mapping, Sequence, Tuple, Union

import numpy as np

from .control_table import Item, Model

__all__ = [
    "QUANTITY_OF_ITEM", "UNIT_OF_QUANTITY", "ZERO_IS_UNLIMITED", "quantity_of", "pulse_to_unit", "under_one_step",
    "unit_to_pulse",
    "encode", "decode", "from_sign_magnitude", "decode_hardware_error", "decode_shutdown", "encode_shutdown",
    "decode_moving_status", "decode_drive_mode", "encode_drive_mode",
    "decode_startup_configuration", "encode_startup_configuration",
]

ArrayLike = Union[int, float, Sequence[float], np.ndarray]

# Item name -> quantity kind. Items not listed are raw (scale 1, no offset).
QUANTITY_OF_ITEM: Mapping[str, str] = {
    "goal_position": "position", "present_position": "position",
    "max_position_limit": "position", "min_position_limit": "position",
    "position_trajectory": "position",
    "homing_offset": "position_offset",
    "goal_velocity": "velocity", "present_velocity": "velocity", "velocity_limit": "velocity",
    "profile_velocity": "velocity", "moving_threshold": "velocity",
    "velocity_trajectory": "velocity",
    "profile_acceleration": "acceleration", "acceleration_limit": "acceleration",
    "goal_current": "current", "present_current": "current", "current_limit": "current",
    "goal_pwm": "pwm", "present_pwm": "pwm", "pwm_limit": "pwm",
    "present_input_voltage": "voltage", "max_voltage_limit": "voltage",
    "min_voltage_limit": "voltage",
    "present_temperature": "temperature", "temperature_limit": "temperature",
    "return_delay_time": "return_delay",
    "bus_watchdog": "bus_watchdog",
    "realtime_tick": "realtime_tick",
    "present_load": "load",
}

UNIT_OF_QUANTITY: Mapping[str, str] = {
    "position": "deg", "position_offset": "deg", "velocity": "deg/s", "acceleration": "deg/s^2",
    "current": "mA", "pwm": "%", "voltage": "V", "temperature": "degC", "return_delay": "us",
    "bus_watchdog": "ms", "realtime_tick": "s", "load": "%", "raw": "",
}

# Quantity -> (Model attribute holding the unit per pulse, uses the model's zero pulse).
_SCALE_SOURCE: Mapping[str, Tuple[str, bool]] = {
    "position": ("position_deg_per_pulse", True),
    "position_offset": ("position_deg_per_pulse", False),
    "velocity": ("velocity_deg_s_per_pulse", False),
    "acceleration": ("acceleration_deg_ss_per_pulse", False),
    "current": ("current_ma_per_pulse", False),
    "pwm": ("pwm_percent_per_pulse", False),
    "voltage": ("voltage_v_per_pulse", False),
    "temperature": ("temperature_degc_per_pulse", False),
    "return_delay": ("return_delay_us_per_pulse", False),
    "bus_watchdog": ("bus_watchdog_ms_per_pulse", False),
    "realtime_tick": ("realtime_tick_s_per_pulse", False),
}
_LOAD_PERCENT_PER_PULSE = 0.1  # Present Load of XL430 / XC430 / 2XL430 / 2XC430


def quantity_of(item: str) -> str:
    """The quantity kind of an item name ("raw" for gains, ids, modes, flags ...)."""
    return QUANTITY_OF_ITEM.get(item, "raw")


class _Plan:
    """Per-element conversion data for one (models, item) combination."""

    __slots__ = ("scale", "offset", "lo", "hi", "missing")

    def __init__(self, models: Tuple[Model, ...], item: str) -> None:
        n = len(models)
        self.scale = np.full(n, np.nan)
        self.offset = np.zeros(n)
        self.lo = np.zeros(n)
        self.hi = np.zeros(n)
        self.missing = np.ones(n, dtype=bool)
        kind = quantity_of(item)
        for i, model in enumerate(models):
            entry = model.items.get(item)
            if entry is None:
                continue
            if kind == "raw":
                scale, offset = 1.0, 0.0
            elif kind == "load":
                scale, offset = _LOAD_PERCENT_PER_PULSE, 0.0
            else:
                attr, zeroed = _SCALE_SOURCE[kind]
                scale = float(model.item_scales.get(item, getattr(model, attr)))
                # the model's zero pulse for positions; an item read with an offset (MX Current:
                # 2048 = 0 mA) its own
                offset = float(model.position_zero_pulse) if zeroed else float(model.item_zero.get(item, 0))
            self.lo[i], self.hi[i] = entry.min_raw, entry.max_raw
            if np.isfinite(scale):
                self.scale[i], self.offset[i] = scale, offset
                self.missing[i] = False
        for arr in (self.scale, self.offset, self.lo, self.hi, self.missing):
            arr.setflags(write=False)


@functools.lru_cache(maxsize=1024)
def _plan(models: Tuple[Model, ...], item: str) -> _Plan:
    return _Plan(models, item)


def _as_vector(values: ArrayLike, n: int, what: str) -> np.ndarray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{what}: expected {n} values (one per model), got shape {arr.shape}")
    return arr


def conversion(models: Sequence[Model], item: str) -> tuple[np.ndarray, np.ndarray]:
    """``(offset, scale)``, one per model, with ``pulse_to_unit`` = ``(pulses - offset) * scale``
    (read-only arrays; NaN scale where a model lacks the item or the quantity)."""
    plan = _plan(tuple(models), item)
    return plan.offset, plan.scale


def pulse_to_unit(models: Sequence[Model], item: str, pulses: ArrayLike) -> np.ndarray:
    """Pulses (one per model) -> physical units as float64; NaN where a model lacks the item or
    the quantity (e.g. current on XL430)."""
    plan = _plan(tuple(models), item)
    raw = _as_vector(pulses, len(plan.scale), "pulse_to_unit")
    out: np.ndarray = (raw - plan.offset) * plan.scale
    return out


#: items whose register value 0 a servo takes for "no limit" (Profile Velocity and Acceleration: an
#: infinite profile; the old Pro's and the MX's Goal Acceleration, here ``profile_acceleration``: no
#: acceleration control): a value above 0 that would round to 0 is written as 1, the smallest step
ZERO_IS_UNLIMITED = frozenset({"profile_velocity", "profile_acceleration"})


def under_one_step(model: Model, item: str, value: float) -> bool:
    """Whether ``value`` (> 0) of a ``ZERO_IS_UNLIMITED`` item is too small to be one register step,
    so ``unit_to_pulse`` writes 1 where rounding gave the "no limit" 0 (the caller says so)."""
    if item not in ZERO_IS_UNLIMITED or not value > 0 or not model.has(item):
        return False
    offset, scale = conversion([model], item)
    return math.isfinite(float(scale[0])) and value / float(scale[0]) + float(offset[0]) < 0.5


def unit_to_pulse(models: Sequence[Model], item: str, values: ArrayLike) -> np.ndarray:
    """Physical units (one per model) -> pulses as int64.

    Rounds half away from zero and clips to what the item's bytes can hold, so a too-large
    command saturates instead of wrapping to the opposite sign. NaN or infinite input raises
    ValueError naming the index; so does a model that lacks the item or its quantity.
    """
    models = tuple(models)
    plan = _plan(models, item)
    vals = _as_vector(values, len(plan.scale), "unit_to_pulse")
    bad = ~np.isfinite(vals)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{item}: value {float(vals[i])} at index {i} is not a finite number")
    if plan.missing.any():
        i = int(np.flatnonzero(plan.missing)[0])
        raise ValueError(f"{item}: model {models[i].name} at index {i} has no such item or unit")
    with np.errstate(over="ignore"):  # a finite value beyond float range saturates like any too-large one
        scaled = vals / plan.scale + plan.offset
    rounded = np.trunc(scaled + np.copysign(0.5, scaled))
    out: np.ndarray = np.clip(rounded, plan.lo, plan.hi).astype(np.int64)
    if item in ZERO_IS_UNLIMITED:
        out[(out == 0) & (vals > 0)] = 1  # a slow profile, never "no limit"
    return out


# ---------------------------------------------------------------------------------------------
# Byte encoding
# ---------------------------------------------------------------------------------------------

_DTYPES: Dict[Tuple[int, bool], str] = {
    (1, False): "<u1", (1, True): "<i1", (2, False): "<u2", (2, True): "<i2",
    (4, False): "<u4", (4, True): "<i4",
}


def _dtype(item: Item) -> np.dtype:
    try:
        return np.dtype(_DTYPES[(item.size, item.signed)])
    except KeyError:
        raise ValueError(f"{item.name}: unsupported item size {item.size}") from None


def encode(item: Item, values: ArrayLike) -> bytes:
    """Values (pulses) -> little-endian bytes, ``item.size`` bytes per value, back to back.

    Out-of-range values raise ValueError instead of wrapping (use ``unit_to_pulse`` to clip).
    """
    arr = np.atleast_1d(np.asarray(values))
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)) or np.any(arr != np.trunc(arr)):
            raise ValueError(f"{item.name}: pulses must be whole numbers, got {arr!r}")
    arr = arr.astype(np.int64)
    out_of_range = (arr < item.min_raw) | (arr > item.max_raw)
    if out_of_range.any():
        i = int(np.flatnonzero(out_of_range)[0])
        raise ValueError(
            f"{item.name}: value {int(arr[i])} at index {i} outside {item.min_raw}..{item.max_raw}")
    if item.direction_bit:  # sign-magnitude: the direction bit set for a negative value
        arr = np.where(arr < 0, -arr | (1 << item.direction_bit), arr)
    return arr.astype(_dtype(item)).tobytes()


def decode(item: Item, raw: Union[bytes, bytearray, memoryview, np.ndarray], n: int = 1) -> np.ndarray:
    """Little-endian bytes -> ``n`` values as int64, sign-extended where the item is signed (or
    sign-magnitude)."""
    buf = np.frombuffer(bytes(raw) if not isinstance(raw, np.ndarray) else
                        np.ascontiguousarray(raw, dtype=np.uint8).tobytes(), dtype=np.uint8)
    need = item.size * n
    if buf.size < need:
        raise ValueError(f"{item.name}: need {need} bytes for {n} values, got {buf.size}")
    values = buf[:need].view(_dtype(item)).astype(np.int64)
    return from_sign_magnitude(values, item.direction_bit) if item.direction_bit else values


def from_sign_magnitude(values: np.ndarray, bit: int) -> np.ndarray:
    """Register values (read unsigned) of a sign-magnitude item -> signed numbers: ``bit`` set
    is the negative (clockwise) direction, the bits below it the magnitude (XL-320 speeds, load)."""
    magnitude = values & ((1 << bit) - 1)
    out: np.ndarray = np.where((values >> bit) & 1 == 1, -magnitude, magnitude)
    return out


# ---------------------------------------------------------------------------------------------
# Bit fields
# ---------------------------------------------------------------------------------------------

# Hardware Error Status and Shutdown share one bit layout (bit 1 is only used by P / PRO).
_ERROR_BITS: Tuple[Tuple[str, int], ...] = (
    ("input_voltage", 0), ("motor_hall_sensor", 1), ("overheating", 2), ("motor_encoder", 3),
    ("electrical_shock", 4), ("overload", 5),
)
_PROFILE_NAMES: Tuple[str, ...] = ("none", "rectangular", "triangular", "trapezoidal")


def _bits(bits: ArrayLike) -> np.ndarray:
    return np.atleast_1d(np.asarray(bits)).astype(np.int64)


def _flag(arr: np.ndarray, bit: int) -> np.ndarray:
    out: np.ndarray = (arr >> bit) & 1 == 1
    return out


def decode_hardware_error(bits: ArrayLike) -> Dict[str, np.ndarray]:
    """Hardware Error Status -> one bool array per cause."""
    arr = _bits(bits)
    return {name: _flag(arr, bit) for name, bit in _ERROR_BITS}


def decode_shutdown(bits: ArrayLike) -> Dict[str, np.ndarray]:
    """Shutdown (which errors switch torque off) -> ``<cause>_error`` bool arrays."""
    arr = _bits(bits)
    return {f"{name}_error": _flag(arr, bit) for name, bit in _ERROR_BITS}


def encode_shutdown(input_voltage_error: bool = False, motor_hall_sensor_error: bool = False,
                    overheating_error: bool = False, motor_encoder_error: bool = False,
                    electrical_shock_error: bool = False, overload_error: bool = False) -> int:
    """Shutdown flags -> register value."""
    flags = (input_voltage_error, motor_hall_sensor_error, overheating_error, motor_encoder_error,
             electrical_shock_error, overload_error)
    return sum(1 << bit for (_, bit), on in zip(_ERROR_BITS, flags) if on)


def decode_moving_status(bits: ArrayLike) -> Dict[str, Union[np.ndarray, List[str]]]:
    """Moving Status -> in_position, profile_ongoing, following_error (bool arrays) and
    velocity_profile (list of "none" | "rectangular" | "triangular" | "trapezoidal")."""
    arr = _bits(bits)
    return {
        "in_position": _flag(arr, 0),
        "profile_ongoing": _flag(arr, 1),
        "following_error": _flag(arr, 3),
        "velocity_profile": [_PROFILE_NAMES[int(v)] for v in (arr >> 4) & 3],
    }


def decode_drive_mode(bits: ArrayLike) -> Dict[str, Union[np.ndarray, List[str]]]:
    """Drive Mode -> reverse_mode, torque_on_by_goal_update (bool arrays) and
    profile_configuration (list of "velocity_based" | "time_based")."""
    arr = _bits(bits)
    return {
        "reverse_mode": _flag(arr, 0),
        "profile_configuration": ["time_based" if v else "velocity_based" for v in _flag(arr, 2)],
        "torque_on_by_goal_update": _flag(arr, 3),
    }


def encode_drive_mode(reverse_mode: bool = False, profile_configuration: str = "velocity_based",
                      torque_on_by_goal_update: bool = False) -> int:
    """Drive Mode fields -> register value (bit 0 reverse, bit 2 time-based, bit 3 torque on by
    goal update)."""
    if profile_configuration not in ("velocity_based", "time_based"):
        raise ValueError(f"profile_configuration must be 'velocity_based' or 'time_based', "
                         f"got {profile_configuration!r}")
    return ((1 if reverse_mode else 0)
            | (4 if profile_configuration == "time_based" else 0)
            | (8 if torque_on_by_goal_update else 0))


def decode_startup_configuration(bits: ArrayLike) -> Tuple[np.ndarray, np.ndarray]:
    """Startup Configuration -> (ram_restore, startup_torque_on) bool arrays."""
    arr = _bits(bits)
    return _flag(arr, 1), _flag(arr, 0)


def encode_startup_configuration(ram_restore: bool = False, startup_torque_on: bool = False) -> int:
    """Startup Configuration fields -> register value."""
    return (2 if ram_restore else 0) | (1 if startup_torque_on else 0)

