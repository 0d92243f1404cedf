"""Factory-default register values for simulated servos.

A virtual servo has to look like one fresh out of the box: the right model number, a firmware
version recent enough for Fast Sync/Bulk Read where the real part supports it, and the factory
values of its model. Those come from the one control table the handler uses too
(``Model.factory``: the e-Manual's initial values per model, limits and gains included); this
module adds what every Protocol 2.0 servo shares (ID, baud 57600, Return Delay Time 250, position
mode, Status Return Level 2, ...) and, for the few values a manual page leaves blank (old PRO
"-R" limits and gains, PRO "-R(A)" gains), representative ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from dynamixel_handler.control_table import Model


@dataclass(frozen=True)
class Family:
    """Facts beyond the control table that pick the firmware and plausible present values."""

    nominal_v: float
    firmware: int
    fast_read: bool
    #: the first firmware version with Fast Sync/Bulk Read
    fast_read_from: int


# Firmware version per control-table layout: X330 v52 (Indirect Data at 208), X430/X540 v48,
# P and PRO "-R(A)" v13 (Fast Read from v12), old PRO "-R" v25 (no fast read), Y v13 (a
# representative number: the Y pages give none; Fast Read is part of its Protocol 2.0).
# Protocol 1.0 firmware (the pages leave it blank): representative numbers, MX from v41 (Realtime
# Tick needs v40 / v41).
_PROTOCOL1_LAYOUTS = ("P1_AX", "P1_RX", "P1_DX", "P1_EX", "P1_MX1")
_FIRMWARE = {"X": 48, "X330": 52, "P": 13, "OLD_PRO": 25, "Y": 13, "XL320": 23,
             **{layout: 24 for layout in _PROTOCOL1_LAYOUTS}, "P1_MX1": 41}
# A layout of a family an installed plug-in adds (``control_table.FamilyPlugin``): a version recent
# enough for Fast Sync/Bulk Read.
_PLUGIN_FIRMWARE = 50
# Layouts without Fast Sync/Bulk Read: old PRO "-R", XL-320 (v23 a representative number), and the
# Protocol 1.0 ones (no such instruction in Protocol 1.0).
_NO_FAST_READ = frozenset({"OLD_PRO", "XL320", *_PROTOCOL1_LAYOUTS})
# The supply a servo runs on, from its factory Max Voltage Limit: 5 V parts (up to 7.0 V), the
# XL-320 (9.0 V: 7.4 V recommended), 12 V parts (up to 16.0 V), 24 V parts; the Protocol 1.0
# servos at a representative 12 V.
_NOMINAL_V = ((70, 5.0), (90, 7.4), (160, 12.0))
_SUPPLY_V = {layout: 12.0 for layout in _PROTOCOL1_LAYOUTS}


def family(model: Model) -> Family:
    """The firmware, the Fast Read support and the supply voltage of a model."""
    max_v = model.factory.get("max_voltage_limit", 400)
    nominal = _SUPPLY_V.get(model.layout) or next((volts for limit, volts in _NOMINAL_V if max_v <= limit), 24.0)
    fast = model.layout not in _NO_FAST_READ and not model.name.startswith("2X")
    fast_from = (46 if model.layout == "X330" else 45) if model.family.x_table else 12
    return Family(nominal, _FIRMWARE.get(model.layout, _PLUGIN_FIRMWARE), fast, fast_from)


def _pulses(value: float, per_pulse: float) -> int:
    if not per_pulse or math.isnan(per_pulse):
        return 0
    return int(round(value / per_pulse))


def _unlisted(model: Model) -> dict[str, int]:
    """Representative values for what a model's e-Manual page leaves blank: the old PRO "-R"
    limits (the position range, the no-load speed, the rated current) and gains, the PRO "-R(A)"
    gains."""
    if model.layout == "OLD_PRO":
        rpm = 29.7 if model.name.startswith("L42") else 33.9
        current_ma = 5000.0 if "54" in model.name else 1870.0
        return {"velocity_limit": _pulses(rpm * 6.0, model.velocity_deg_s_per_pulse),
                "current_limit": _pulses(current_ma, model.current_ma_per_pulse),
                "acceleration_limit": 10000,
                "max_position_limit": model.position_max_pulse,
                "min_position_limit": model.position_min_pulse,
                "velocity_i_gain": 16, "velocity_p_gain": 600, "position_p_gain": 32}
    if model.family.x_table:
        return {}
    return {"velocity_i_gain": 16, "velocity_p_gain": 600, "position_p_gain": 32}


# What every servo of the series holds when unboxed (the e-Manual's initial values).
_COMMON = {
    "model_information": 0, "baud_rate": 1, "return_delay_time": 250, "drive_mode": 0,
    "operating_mode": 3, "secondary_id": 255, "protocol_type": 2, "homing_offset": 0,
    "startup_configuration": 0, "torque_enable": 0, "led": 0, "led_red": 0, "led_green": 0,
    "led_blue": 0, "status_return_level": 2, "registered_instruction": 0, "hardware_error_status": 0,
    "position_d_gain": 0, "position_i_gain": 0, "feedforward_2nd_gain": 0, "feedforward_1st_gain": 0,
    "bus_watchdog": 0, "goal_pwm": 0, "goal_current": 0, "goal_velocity": 0, "profile_acceleration": 0,
    "profile_velocity": 0, "goal_position": 0, "backup_ready": 0,
    **{f"external_port_data_{n}": 0 for n in (1, 2, 3, 4)},
}


def factory_defaults(model: Model, servo_id: int) -> dict[str, int]:
    """Every register a factory-fresh servo of ``model`` holds, by canonical name."""
    values = dict(_COMMON)
    values.update(_unlisted(model))
    values.update(model.factory)
    values.update(model_number=model.number, firmware_version=family(model).firmware, id=servo_id)
    return {name: value for name, value in values.items() if model.has(name)}


# Gains and profiles a mode change puts back (the e-Manual: changing the mode resets them).
MODE_RESET_ITEMS = ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain",
                    "position_p_gain", "feedforward_2nd_gain", "feedforward_1st_gain",
                    "profile_acceleration", "profile_velocity")

# Items a host may never write.
READ_ONLY = frozenset({
    "model_number", "model_information", "firmware_version", "registered_instruction",
    "hardware_error_status", "realtime_tick", "moving", "moving_status", "present_pwm",
    "present_current", "present_load", "present_velocity", "present_position",
    "velocity_trajectory", "position_trajectory", "present_input_voltage", "present_temperature",
    "backup_ready", "error_code", "controller_state", "present_inverter_temperature",
    *(f"error_code_history_{n}" for n in range(1, 17)),
})
