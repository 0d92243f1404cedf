"""Servo table -> state messages, as nested dicts of numpy arrays (``cdr.Codec`` encodes them to
bytes or builds rclpy objects from them). Items a series lacks come out NaN / 0 / "" / false.

``Cache`` keeps unit conversions and group messages from one loop to the next: the servo table
replaces an item's arrays when it stores new values and never changes them in place
(``ServoTable.arrays``), so the same arrays give the same message, which is built once and then
kept read-only (``lean.Patcher`` skips re-encoding what it has already written)."""
from __future__ import annotations

import array
import math
from typing import Any, Callable, Iterable, Mapping

import numpy as np
from builtin_interfaces.msg import Time

from .. import units
from ..servo import error_state
from ..servo.groups import ERROR_ITEMS, GAIN, GOAL, LIMIT, PRESENT, STATUS_ITEMS
from ..servo.table import ServoTable

Tree = dict[str, Any]
Units = Callable[[str], np.ndarray]  # item -> its values in physical units (``ServoTable.units``)


def f64(values: np.ndarray) -> array.array:
    """For rclpy message objects: array.array is copied without per-element checks."""
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def u16(values: Iterable[int] | np.ndarray) -> np.ndarray:
    return np.clip(np.asarray(values, dtype=np.int64), 0, 65535).astype(np.uint16)


def stamp_of(seconds: float) -> Time:
    sec, nanosec = _stamp(seconds)
    return Time(sec=sec, nanosec=nanosec)


def _stamp(seconds: float) -> tuple[int, int]:
    sec = math.floor(seconds)
    return int(sec), min(int((seconds - sec) * 1e9), 999_999_999)


def _flag(table: ServoTable, item: str) -> np.ndarray:
    return (table.pulses(item) != 0) & table.known(item)


def status(table: ServoTable) -> Tree:
    known = table.known("operating_mode")
    return {"id_list": u16(table.ids), "torque": _flag(table, "torque_enable"),
            "error": error_state.in_error(table), "ping": table.ping.copy(),
            "mode": [(m.mode_name(int(v)) or "") if k else ""
                     for v, k, m in zip(table.pulses("operating_mode"), known, table.models)]}


def present(table: ServoTable, keys: Iterable[str] | None = None, units: Units | None = None) -> Tree:
    """Present values; with ``keys`` only those items are filled (the others stay empty)."""
    units = units or table.units
    msg: Tree = {"id_list": u16(table.ids)}
    wanted = set(PRESENT) if keys is None else set(keys)
    for key, (item, field) in PRESENT.items():
        if key in wanted:
            msg[field] = units(item)
    return msg


def _in_units(table: ServoTable, fields: Mapping[str, str], units: Units | None = None) -> Tree:
    """id_list and each item of ``fields`` (item -> message field) in physical units."""
    units = units or table.units
    msg: Tree = {"id_list": u16(table.ids)}
    for item, field in fields.items():
        msg[field] = units(item)
    return msg


def goal(table: ServoTable, units: Units | None = None) -> Tree:
    return _in_units(table, GOAL, units)


def gain(table: ServoTable) -> Tree:
    msg: Tree = {"id_list": u16(table.ids)}
    for item, field in GAIN.items():
        msg[field] = u16(np.where(table.known(item), table.pulses(item), 0))
    return msg


def limit(table: ServoTable, units: Units | None = None) -> Tree:
    return _in_units(table, LIMIT, units)


def error(table: ServoTable) -> Tree:
    msg: Tree = {"id_list": u16(table.ids)}
    bits = error_state.hardware_bits(table)  # a Y error code as the bits it stands for
    for name, flags in units.decode_hardware_error(bits).items():
        msg[name] = np.asarray(flags, dtype=bool)
    return msg


def _led(table: ServoTable) -> Tree:
    """LED brightness per colour in %: P / Pro 0..255 per colour; X one LED (red) on or off; XL-320
    one colour of three bits (0 red, 1 green, 2 blue), each on or off."""
    colour_known, colour = table.known("led_colour"), table.pulses("led_colour")
    out: Tree = {}
    for bit, name in enumerate(("red", "green", "blue")):
        fallback = np.where(colour_known, ((colour >> bit) & 1) * 100.0, np.nan)
        if name == "red":  # X: one LED
            fallback = np.where(table.known("led"), table.pulses("led") * 100.0, fallback)
        out[f"{name}_percent"] = np.where(table.known(f"led_{name}"), table.pulses(f"led_{name}") * 100.0 / 255.0, fallback)
    return out


def extra(table: ServoTable) -> Tree:
    n = len(table)
    has = table.known("moving_status")
    moving = units.decode_moving_status(table.pulses("moving_status"))
    moving_status: Tree = {"velocity_profile": [p if k else "none" for p, k in zip(moving["velocity_profile"], has)]}
    for name in ("following_error", "profile_ongoing", "in_position"):
        moving_status[name] = np.asarray(moving[name], dtype=bool) & has
    has = table.known("drive_mode")
    drive = units.decode_drive_mode(table.pulses("drive_mode"))
    drive_mode = {"torque_on_by_goal_update": np.asarray(drive["torque_on_by_goal_update"], bool) & has,
                  "profile_configuration": [c if k else "velocity_based" for c, k in zip(drive["profile_configuration"], has)],
                  "reverse_mode": np.asarray(drive["reverse_mode"], bool) & has}
    has = table.known("startup_configuration")
    ram_restore, startup_torque = units.decode_startup_configuration(table.pulses("startup_configuration"))
    has_shutdown = table.known("shutdown")
    return {
        "id_list": u16(table.ids),
        "model": [m.family.title for m in table.models],  # the series (design); the
        # model itself is model_number (and its name is in the start-up log)
        "model_number": u16([m.number for m in table.models]),
        # the old Pro has no Protocol Type register: it speaks Protocol 2.0 only
        "protocol_type": u16(np.where(table.known("protocol_type"), table.pulses("protocol_type"),
                                      [0 if m.family.has_protocol_type else 2 for m in table.models])),
        "firmware_version": u16(table.pulses("firmware_version")),
        "realtime_tick_s": table.units("realtime_tick"),
        "moving_status": moving_status,
        "moving": _flag(table, "moving"),
        "return_delay_time_us": table.units("return_delay_time"),
        "drive_mode": drive_mode,
        "shadow_id": u16(table.pulses("secondary_id")),
        "homing_offset_deg": table.units("homing_offset"),
        "moving_threshold_deg_s": table.units("moving_threshold"),
        "restore_configuration": {"ram_restore": np.asarray(ram_restore, bool) & has,
                                  "startup_torque_on": np.asarray(startup_torque, bool) & has},
        "pwm_slope_percent": np.where(table.known("pwm_slope"), table.pulses("pwm_slope"), np.nan).astype(np.float64),
        "shutdown": {name: np.asarray(flags, bool) & has_shutdown for name, flags in units.decode_shutdown(
            error_state.common_array(table.models, table.pulses("shutdown"))).items()},  # XL-320: its own bit order
        "led": _led(table),
        "bus_watchdog_ms": table.units("bus_watchdog"),
        "reboot": np.zeros(n, dtype=bool),
    }


def debug(table: ServoTable, status_msg: Tree | None = None, units: Units | None = None) -> Tree:
    units = units or table.units
    msg: Tree = {"status": status_msg if status_msg is not None else status(table)}
    for field, now, want in (("current_ma", "present_current", "goal_current"),
                             ("velocity_deg_s", "present_velocity", "goal_velocity"),
                             ("position_deg", "present_position", "goal_position")):
        msg[field] = {"present": units(now), "goal": units(want)}
    return msg


class Parts:
    """The group messages of one loop, each built once however many topics carry it; with a
    ``Cache``, taken from the previous loops when the table arrays they come from are the same."""

    BUILDERS = {"status": status, "goal": goal, "gain": gain, "limit": limit, "error": error, "extra": extra}

    def __init__(self, table: ServoTable, present_keys: set[str], outdated_present: bool,
                 cache: Cache | None = None) -> None:
        self.table = table
        self.present_keys = None if outdated_present else present_keys
        self._built: dict[str, Tree] = {}
        self.cache = cache
        if cache is not None:
            cache.check(table)

    def units(self, item: str) -> np.ndarray:
        return self.table.units(item) if self.cache is None else self.cache.units(self.table, item)

    def get(self, name: str) -> Tree:
        msg = self._built.get(name)
        if msg is None:
            msg = self._built[name] = self._cached(name) if self.cache is not None else self._build(name)
        return msg

    def _build(self, name: str) -> Tree:
        if name == "present":
            return present(self.table, self.present_keys, self.units)
        if name in ("goal", "limit"):
            return _in_units(self.table, GOAL if name == "goal" else LIMIT, self.units)
        return self.BUILDERS[name](self.table)

    def _cached(self, name: str) -> Tree:
        assert self.cache is not None
        table, keys = self.table, self.present_keys
        if name == "present":  # read again in most loops: built each time, from the kept conversions
            msg: Tree = {"id_list": self.cache.id_list}
            units = self.units
            for key, (item, field) in PRESENT.items():
                if keys is None or key in keys:
                    msg[field] = units(item)
            return msg
        if name == "status":  # ping is copied with the table (snapshot): compared by value
            return self.cache.group(name, table, STATUS_ITEMS, lambda: self._build(name), table.ping.tobytes())
        if name in _SOURCES:
            return self.cache.group(name, table, _SOURCES[name], lambda: self._build(name))
        return self._build(name)  # extra: seldom read, built from many items


#: the table items each cached group message is built from (besides the IDs and models)
_SOURCES: dict[str, tuple[str, ...]] = {"goal": tuple(GOAL), "limit": tuple(LIMIT), "gain": tuple(GAIN),
                                        "error": ERROR_ITEMS}


class Cache:
    """Unit conversions and group messages kept from loop to loop (see the module's doc); all
    forgotten when the servos (IDs or models) change. What it hands out is read-only."""

    def __init__(self) -> None:
        self._ids: list[int] | None = None
        self._models: list[Any] | None = None
        self._units: dict[str, tuple[Any, Any, np.ndarray]] = {}
        self._groups: dict[str, tuple[list[tuple[Any, Any]], Any, Tree]] = {}
        self.id_list = u16([])
        #: counts the times everything was forgotten
        self.epoch = 0

    def check(self, table: ServoTable) -> None:
        if table.ids != self._ids or table.models != self._models:
            self._ids, self._models = list(table.ids), list(table.models)
            self._units.clear()
            self._groups.clear()
            self.epoch += 1
            self.id_list = u16(table.ids)
            self.id_list.setflags(write=False)

    def units(self, table: ServoTable, item: str) -> np.ndarray:
        raw, known = table.arrays(item)
        hit = self._units.get(item)
        if hit is not None and hit[0] is raw and hit[1] is known:
            return hit[2]
        value = table.units(item)
        self._units[item] = (raw, known, value)
        return value

    def items_of(self) -> dict[int, str]:
        """id() of each kept conversion -> its item."""
        return {id(hit[2]): item for item, hit in self._units.items()}

    def group(self, name: str, table: ServoTable, items: Iterable[str], build: Callable[[], Tree],
              also: Any = None) -> Tree:
        """The message ``build()`` makes from ``items`` (and ``also``, compared by value)."""
        sources = [table.arrays(item) for item in items]
        hit = self._groups.get(name)
        if hit is not None and hit[1] == also and len(hit[0]) == len(sources) and all(
                a[0] is b[0] and a[1] is b[1] for a, b in zip(hit[0], sources)):
            return hit[2]
        msg = _read_only(build())
        msg["id_list"] = self.id_list  # the same values, as the same array every loop
        self._groups[name] = (sources, also, msg)
        return msg


def _read_only(tree: Tree) -> Tree:
    for value in tree.values():
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
        elif isinstance(value, dict):
            _read_only(value)
    return tree


def states(table: ServoTable, stamp: float, groups: set[str], present_keys: set[str],
           outdated_present: bool, parts: Parts | None = None) -> Tree:
    """The program-facing message: only the groups read in this loop are filled."""
    parts = parts or Parts(table, present_keys, outdated_present)
    sec, nanosec = _stamp(stamp)
    msg: Tree = {"stamp": {"sec": sec, "nanosec": nanosec}}
    for name in ("status", "goal", "gain", "limit", "error"):
        if name in groups:
            msg[name] = parts.get(name)
    if present_keys:
        msg["present"] = parts.get("present")
    if groups & {"extra_dynamic", "extra_static"}:
        msg["extra"] = parts.get("extra")
    return msg
