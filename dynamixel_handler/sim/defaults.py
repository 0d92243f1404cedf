"""Factory-default register values for simulated servos.

A virtual servo has to look like one fresh out of the box: the right model number, a
firmware version recent enough for Fast Sync/Bulk Read where the real part supports it,
plausible limits and gains. Values follow the e-Manual defaults where they matter to a
user (baud 57600, return delay 250, position mode, status return level 2, shutdown mask,
limits); gains are representative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from dynamixel_handler.control_table import Model


@dataclass(frozen=True)
class Family:
    """Electrical/mechanical facts that pick defaults and plausible present values."""

    no_load_rpm: float
    current_limit_ma: float
    nominal_v: float
    max_v: float
    min_v: float
    firmware: int
    fast_read: bool


def family(model: Model) -> Family:
    """Pick the facts for a model from its name (series, size, gear)."""
    name = model.name
    if model.series == "X":
        fast = not name.startswith("2X")
        if name.startswith("XM335"):
            return Family(53.0, 910.0, 11.1, 140.0, 55.0, 52, fast)
        if model.layout == "X330":  # firmware v52: the Indirect Data block at 208
            return Family(104.0 if "M288" in name else 383.0, 1750.0, 5.0, 70.0, 35.0, 52, fast)
        if name.startswith(("XL430", "XC430", "2XL", "2XC")):
            return Family(61.0, math.nan, 12.0, 140.0, 60.0, 48, fast)
        if "540" in name:
            rpm = 30.0 if "270" in name or "260" in name else 53.0
            return Family(rpm, 2047 * 2.69, 12.0, 160.0, 95.0, 48, fast)
        rpm = 46.0 if "350" in name or "333" in name else 77.0
        return Family(rpm, 1193 * 2.69, 12.0, 160.0, 95.0, 48, fast)
    if model.has("drive_mode"):  # P series and PRO "-R(A)": P firmware, Fast Read from v12
        big = "54" in name
        current = 22740.0 if "200" in name else (15900.0 if big else 4500.0)
        return Family(29.0, current, 24.0, 350.0, 150.0, 13, True)
    # old PRO "-R" firmware (H, M and L series): no fast read, no PWM, no drive mode
    current = 5000.0 if "54" in name else 1870.0
    rpm = 29.7 if name.startswith("L42") else 33.9
    return Family(rpm, current, 24.0, 400.0, 150.0, 25, False)


def _pulses(value: float, per_pulse: float, fallback: int) -> int:
    if not per_pulse or math.isnan(per_pulse) or math.isnan(value):
        return fallback
    return int(round(value / per_pulse))


def factory_defaults(model: Model, servo_id: int) -> dict[str, int]:
    """Every register a factory-fresh servo of ``model`` holds, by canonical name."""
    fam = family(model)
    velocity_limit = _pulses(fam.no_load_rpm * 6.0, model.velocity_deg_s_per_pulse, 200)
    x = model.series == "X"
    values = {
        "model_number": model.number,
        "model_information": 0,
        "firmware_version": fam.firmware,
        "id": servo_id,
        "baud_rate": 3 if model.name.startswith("XM335") else 1,  # e-Manual: 1 Mbps / 57600 bps
        "return_delay_time": 250,  # 500 us
        "drive_mode": 0,
        "operating_mode": 3,
        "secondary_id": 255,
        "protocol_type": 2,
        "homing_offset": 0,
        "moving_threshold": 10 if x else (20 if model.layout == "P" else 50),  # e-Manual: X 10, P 20
        "temperature_limit": 70 if "330" in model.name else 80,
        "max_voltage_limit": int(fam.max_v),
        "min_voltage_limit": int(fam.min_v),
        "pwm_limit": 885 if x else 2009,
        "current_limit": _pulses(fam.current_limit_ma, model.current_ma_per_pulse, 0),
        "acceleration_limit": 32767 if x else 10000,
        "velocity_limit": velocity_limit,
        "max_position_limit": model.position_max_pulse,
        "min_position_limit": model.position_min_pulse,
        "startup_configuration": 0,
        "pwm_slope": 140,
        "shutdown": 58 if model.layout == "OLD_PRO" else 52,  # e-Manual: X and P 52
        "torque_enable": 0,
        "led": 0, "led_red": 0, "led_green": 0, "led_blue": 0,
        "status_return_level": 2,
        "registered_instruction": 0,
        "hardware_error_status": 0,
        "velocity_i_gain": 1920 if x else 16,
        "velocity_p_gain": 100 if x else 600,
        "position_d_gain": 0,
        "position_i_gain": 0,
        "position_p_gain": 800 if x else 32,
        "feedforward_2nd_gain": 0,
        "feedforward_1st_gain": 0,
        "bus_watchdog": 0,
        "goal_pwm": 0,
        "goal_current": 0,
        "goal_velocity": 0,
        "profile_acceleration": 0,
        "profile_velocity": 0,
        "goal_position": 0,
        "backup_ready": 0,
    }
    for port in model.external_ports:
        values[f"external_port_mode_{port}"] = 3  # digital input, pull-down
        values[f"external_port_data_{port}"] = 0
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
    "backup_ready",
})
