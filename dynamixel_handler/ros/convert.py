"""Servo table -> state messages. Arrays go in as array.array so rclpy copies them without
checking element by element; items a series lacks come out NaN / 0 / "" / false."""
from __future__ import annotations

import array
import math
from typing import Iterable

import numpy as np
from builtin_interfaces.msg import Time

from dynamixel_handler_msgs.msg import (DxlStates, DynamixelDebug, DynamixelError, DynamixelExtra, DynamixelGain,
                                        DynamixelGoal, DynamixelLimit, DynamixelPresent, DynamixelStatus)

from .. import units
from ..groups import GAIN, GOAL, LIMIT, MODE_NAMES, PRESENT
from ..servos import ServoTable


def f64(values: np.ndarray) -> array.array:
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def u16(values: Iterable[int] | np.ndarray) -> array.array:
    arr = np.clip(np.asarray(values, dtype=np.int64), 0, 65535).astype(np.uint16)
    out = array.array("H")
    out.frombytes(arr.tobytes())
    return out


def stamp_of(seconds: float) -> Time:
    sec = math.floor(seconds)
    return Time(sec=int(sec), nanosec=int((seconds - sec) * 1e9))


def _flag(table: ServoTable, item: str) -> np.ndarray:
    return (table.pulses(item) != 0) & table.known(item)


def status(table: ServoTable) -> DynamixelStatus:
    msg = DynamixelStatus()
    msg.id_list = u16(table.ids)
    msg.torque = _flag(table, "torque_enable").tolist()
    msg.error = _flag(table, "hardware_error_status").tolist()
    msg.ping = table.ping.tolist()
    known = table.known("operating_mode")
    msg.mode = [MODE_NAMES.get(int(v), "") if k else "" for v, k in zip(table.pulses("operating_mode"), known)]
    return msg


def present(table: ServoTable, keys: Iterable[str] | None = None) -> DynamixelPresent:
    """Present values; with ``keys`` only those items are filled (the others stay empty)."""
    msg = DynamixelPresent()
    msg.id_list = u16(table.ids)
    wanted = set(PRESENT) if keys is None else set(keys)
    for key, (item, field) in PRESENT.items():
        if key in wanted:
            setattr(msg, field, f64(table.units(item)))
    return msg


def goal(table: ServoTable) -> DynamixelGoal:
    msg = DynamixelGoal()
    msg.id_list = u16(table.ids)
    for item, field in GOAL.items():
        setattr(msg, field, f64(table.units(item)))
    return msg


def gain(table: ServoTable) -> DynamixelGain:
    msg = DynamixelGain()
    msg.id_list = u16(table.ids)
    for item, field in GAIN.items():
        setattr(msg, field, u16(np.where(table.known(item), table.pulses(item), 0)))
    return msg


def limit(table: ServoTable) -> DynamixelLimit:
    msg = DynamixelLimit()
    msg.id_list = u16(table.ids)
    for item, field in LIMIT.items():
        setattr(msg, field, f64(table.units(item)))
    return msg


def error(table: ServoTable) -> DynamixelError:
    msg = DynamixelError()
    msg.id_list = u16(table.ids)
    bits = np.where(table.known("hardware_error_status"), table.pulses("hardware_error_status"), 0)
    for name, flags in units.decode_hardware_error(bits).items():
        setattr(msg, name, np.asarray(flags, dtype=bool).tolist())
    return msg


def extra(table: ServoTable) -> DynamixelExtra:
    msg = DynamixelExtra()
    n = len(table)
    msg.id_list = u16(table.ids)
    msg.model = [m.name for m in table.models]
    msg.model_number = u16([m.number for m in table.models])
    msg.protocol_type = u16(np.where(table.known("protocol_type"), table.pulses("protocol_type"), 0))
    msg.firmware_version = u16(table.pulses("firmware_version"))
    msg.realtime_tick_s = f64(table.units("realtime_tick"))
    has = table.known("moving_status")
    moving = units.decode_moving_status(table.pulses("moving_status"))
    msg.moving_status.velocity_profile = [p if k else "none" for p, k in zip(moving["velocity_profile"], has)]
    for name in ("following_error", "profile_ongoing", "in_position"):
        setattr(msg.moving_status, name, (np.asarray(moving[name], dtype=bool) & has).tolist())
    msg.moving = _flag(table, "moving").tolist()
    msg.return_delay_time_us = f64(table.units("return_delay_time"))
    has = table.known("drive_mode")
    drive = units.decode_drive_mode(table.pulses("drive_mode"))
    msg.drive_mode.torque_on_by_goal_update = (np.asarray(drive["torque_on_by_goal_update"], bool) & has).tolist()
    msg.drive_mode.profile_configuration = [c if k else "velocity_based"
                                            for c, k in zip(drive["profile_configuration"], has)]
    msg.drive_mode.reverse_mode = (np.asarray(drive["reverse_mode"], bool) & has).tolist()
    msg.shadow_id = u16(table.pulses("secondary_id"))
    msg.homing_offset_deg = f64(table.units("homing_offset"))
    msg.moving_threshold_deg_s = f64(table.units("moving_threshold"))
    has = table.known("startup_configuration")
    ram_restore, startup_torque = units.decode_startup_configuration(table.pulses("startup_configuration"))
    msg.restore_configuration.ram_restore = (np.asarray(ram_restore, bool) & has).tolist()
    msg.restore_configuration.startup_torque_on = (np.asarray(startup_torque, bool) & has).tolist()
    msg.pwm_slope_percent = f64(np.where(table.known("pwm_slope"), table.pulses("pwm_slope"), np.nan))
    has = table.known("shutdown")
    for name, flags in units.decode_shutdown(table.pulses("shutdown")).items():
        setattr(msg.shutdown, name, (np.asarray(flags, bool) & has).tolist())
    led = np.where(table.known("led"), table.pulses("led") * 100.0, np.nan)
    msg.led.red_percent = f64(np.where(table.known("led_red"), table.pulses("led_red") / 2.55, led))
    msg.led.green_percent = f64(np.where(table.known("led_green"), table.pulses("led_green") / 2.55, np.nan))
    msg.led.blue_percent = f64(np.where(table.known("led_blue"), table.pulses("led_blue") / 2.55, np.nan))
    msg.bus_watchdog_ms = f64(table.units("bus_watchdog"))
    msg.reboot = [False] * n
    return msg


def debug(table: ServoTable, status_msg: DynamixelStatus | None = None) -> DynamixelDebug:
    msg = DynamixelDebug()
    msg.status = status_msg if status_msg is not None else status(table)
    for field, now, want in (("current_ma", "present_current", "goal_current"),
                             ("velocity_deg_s", "present_velocity", "goal_velocity"),
                             ("position_deg", "present_position", "goal_position")):
        element = getattr(msg, field)
        element.present = f64(table.units(now))
        element.goal = f64(table.units(want))
    return msg


class Parts:
    """The group messages of one loop, each built once however many topics carry it."""

    BUILDERS = {"status": status, "goal": goal, "gain": gain, "limit": limit, "error": error, "extra": extra}

    def __init__(self, table: ServoTable, present_keys: set[str], outdated_present: bool) -> None:
        self.table = table
        self.present_keys = None if outdated_present else present_keys
        self._built: dict[str, object] = {}

    def get(self, name: str):
        msg = self._built.get(name)
        if msg is None:
            msg = (present(self.table, self.present_keys) if name == "present"
                   else self.BUILDERS[name](self.table))
            self._built[name] = msg
        return msg


def states(table: ServoTable, stamp: float, groups: set[str], present_keys: set[str],
           outdated_present: bool, parts: Parts | None = None) -> DxlStates:
    """The program-facing message: only the groups read in this loop are filled."""
    parts = parts or Parts(table, present_keys, outdated_present)
    msg = DxlStates()
    msg.stamp = stamp_of(stamp)
    for name in ("status", "goal", "gain", "limit", "error"):
        if name in groups:
            setattr(msg, name, parts.get(name))
    if present_keys:
        msg.present = parts.get("present")
    if groups & {"extra_dynamic", "extra_static"}:
        msg.extra = parts.get("extra")
    return msg
