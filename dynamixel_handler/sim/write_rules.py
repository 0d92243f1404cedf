"""The firmware's checks of one written value: the error a servo answers, or none.

A value outside an item's range (the model's e-Manual range, ``Model.ranges``: a gain, a limit or a
Status Return Level beyond it; an unknown operating mode or baud rate) is a Data Range Error; a goal
beyond its limit a Data Limit Error; goals after a bus watchdog error a Data Range Error; Torque Enable while a shutdown error is latched a
Result Fail. ``changes`` are the other items of the same write: a limit written together with a
goal counts for it.
"""

from __future__ import annotations

import math
from typing import Sequence

from dynamixel_handler.control_table import Item

from ..protocol import servo as p
from . import error_codes
from .defaults import READ_ONLY
from .registers import Registers

EXTENDED_MODES = (4, 5)
X_EXTENDED_GOAL_LIMIT = 1_048_575
_GOAL_LIMITS = {"goal_pwm": "pwm_limit", "goal_current": "current_limit", "goal_velocity": "velocity_limit"}

Changes = Sequence[tuple[Item, int]]


def check_write(servo: Registers, address: int, data: bytes,
                latched: bool = False) -> tuple[int, list[tuple[Item, int]]]:
    """Validate a write without applying it; returns (error, [(item, value)]).

    Indirect Data bytes count as the items they map; plain Indirect Data storage is
    returned as pseudo items of one byte."""
    error, changes, raw = servo.file.gather(address, data)
    if error:
        return error, []
    torque_on = servo.peek("torque_enable") == 1
    lo, hi = servo.model.indirect_targets
    for it, value in changes:
        if it.name in READ_ONLY:
            return p.ERR_ACCESS, []
        if it.eeprom and torque_on:
            return p.ERR_ACCESS, []
        if it.name.startswith("indirect_address_"):
            if not lo <= value <= hi:
                return p.ERR_DATA_RANGE, []
            continue
        error = check_value(servo, it.name, value, changes, latched)
        if error:
            return error, []
    return p.ERR_NONE, changes + [(Item(f"indirect_data_{a}", a, 1, False, False), b) for a, b in raw]


def check_value(servo: Registers, name: str, value: int, changes: Changes, latched: bool = False) -> int:
    """The error code a servo answers to ``value`` written to item ``name`` (ERR_NONE: accepted);
    ``latched``: a shutdown error holds (torque on is refused)."""
    return (_range_error(servo, name, value) or _setting_error(servo, name, value, latched)
            or _limit_error(servo, name, value, changes))


def _range(servo: Registers, name: str) -> tuple[int, int] | None:
    """The values the model's e-Manual allows the item (``Model.ranges``; the position limits: the
    model's position range); None: any its bytes hold."""
    model = servo.model
    if name in ("max_position_limit", "min_position_limit"):
        return model.position_min_pulse, model.position_max_pulse
    return model.ranges.get(name)


def _range_error(servo: Registers, name: str, value: int) -> int:
    bounds = _range(servo, name)
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        return p.ERR_DATA_RANGE
    return p.ERR_NONE


def _setting_error(servo: Registers, name: str, value: int, latched: bool) -> int:
    """Enumerated settings the model does not have, goals after a watchdog trip, torque on
    while a shutdown error holds."""
    if name in ("operating_mode", "baud_rate", "drive_mode"):
        return p.ERR_NONE if _known_setting(servo, name, value) else p.ERR_DATA_RANGE
    if name.startswith("goal_") and (servo.get("bus_watchdog") < 0 or error_codes.holds(servo)):
        return p.ERR_DATA_RANGE  # goals are read-only after a bus watchdog error (Y: a hold error)
    if name == "torque_enable" and value == 1 and latched:
        return p.ERR_RESULT_FAIL
    return p.ERR_NONE


def _known_setting(servo: Registers, name: str, value: int) -> bool:
    model = servo.model
    if name == "operating_mode":  # current control needs a current sensor
        return value in model.operating_modes and not (value == 0 and math.isnan(model.current_ma_per_pulse))
    if name == "baud_rate":
        return value in servo.baud_rates
    return not (servo.x and value & ~0x0D)  # X drive mode: bits 0, 2 and 3


def _limit_error(servo: Registers, name: str, value: int, changes: Changes) -> int:
    def new(item: str) -> int:
        for it, v in changes:
            if it.name == item:
                return v
        return servo.get(item)

    limit = _GOAL_LIMITS.get(name)
    if limit is not None and servo.has(limit) and abs(value) > new(limit):
        return p.ERR_DATA_LIMIT
    if name == "goal_position":
        mode = new("operating_mode")
        if servo.model.mode_name(mode) in servo.model.position_limited_modes and \
                not new("min_position_limit") <= value <= new("max_position_limit"):
            return p.ERR_DATA_LIMIT
        if mode in EXTENDED_MODES and servo.x and abs(value) > X_EXTENDED_GOAL_LIMIT:
            return p.ERR_DATA_LIMIT
    return p.ERR_NONE
