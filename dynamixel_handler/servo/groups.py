"""Which control-table items make up each state group, and how each maps onto a message field.

A *group* is what one ``pub_ratio`` governs and one state message carries: status, present, goal,
gain, limit, error, extra (dynamic and static). Present items each have their own ratio
(``pub_ratio/present.<key>``). ROS-free: field names are the domain's, shared with the messages.
"""
from __future__ import annotations

from typing import Mapping

#: present: ratio key -> (item, message field)
PRESENT: Mapping[str, tuple[str, str]] = {
    "pwm": ("present_pwm", "pwm_percent"),
    "current": ("present_current", "current_ma"),
    "velocity": ("present_velocity", "velocity_deg_s"),
    "position": ("present_position", "position_deg"),
    "velocity_trajectory": ("velocity_trajectory", "vel_trajectory_deg_s"),
    "position_trajectory": ("position_trajectory", "pos_trajectory_deg"),
    "input_voltage": ("present_input_voltage", "input_voltage_v"),
    "temperature": ("present_temperature", "temperature_degc"),
}

#: goal: item -> message field (physical units)
GOAL: Mapping[str, str] = {
    "goal_pwm": "pwm_percent",
    "goal_current": "current_ma",
    "goal_velocity": "velocity_deg_s",
    "goal_position": "position_deg",
    "profile_velocity": "profile_vel_deg_s",
    "profile_acceleration": "profile_acc_deg_ss",
}

#: gain: item -> message field (raw pulses)
GAIN: Mapping[str, str] = {
    "velocity_i_gain": "velocity_i_gain_pulse",
    "velocity_p_gain": "velocity_p_gain_pulse",
    "position_d_gain": "position_d_gain_pulse",
    "position_i_gain": "position_i_gain_pulse",
    "position_p_gain": "position_p_gain_pulse",
    "feedforward_2nd_gain": "feedforward_2nd_gain_pulse",
    "feedforward_1st_gain": "feedforward_1st_gain_pulse",
}

#: limit: item -> message field (physical units)
LIMIT: Mapping[str, str] = {
    "temperature_limit": "temperature_limit_degc",
    "max_voltage_limit": "max_voltage_limit_v",
    "min_voltage_limit": "min_voltage_limit_v",
    "pwm_limit": "pwm_limit_percent",
    "current_limit": "current_limit_ma",
    "acceleration_limit": "acceleration_limit_deg_ss",
    "velocity_limit": "velocity_limit_deg_s",
    "max_position_limit": "max_position_limit_deg",
    "min_position_limit": "min_position_limit_deg",
}

# a servo reports its errors in Hardware Error Status, or (Y) in Error Code (``error_state``)
STATUS_ITEMS = ("operating_mode", "torque_enable", "hardware_error_status", "error_code")
ERROR_ITEMS = ("hardware_error_status", "error_code")
EXTRA_DYNAMIC_ITEMS = ("led", "led_red", "led_green", "led_blue", "led_colour", "realtime_tick", "moving",
                       "moving_status", "bus_watchdog")
EXTRA_STATIC_ITEMS = ("model_number", "firmware_version", "return_delay_time", "drive_mode", "secondary_id",
                      "protocol_type", "homing_offset", "moving_threshold", "startup_configuration", "pwm_slope",
                      "shutdown")

#: group name -> items read for it (present is per ratio key, see PRESENT)
GROUP_ITEMS: Mapping[str, tuple[str, ...]] = {
    "status": STATUS_ITEMS,
    "goal": tuple(GOAL),
    "gain": tuple(GAIN),
    "limit": tuple(LIMIT),
    "error": ERROR_ITEMS,
    "extra_dynamic": EXTRA_DYNAMIC_ITEMS,
    "extra_static": EXTRA_STATIC_ITEMS,
}

#: operating mode register value -> mode string of DynamixelStatus
MODE_NAMES: Mapping[int, str] = {0: "current", 1: "velocity", 3: "position", 4: "ex_position",
                                 5: "cur_position", 16: "pwm"}


def due(ratio: int, loop_count: int) -> bool:
    """Whether a group with this ratio is read in loop ``loop_count`` (0 = the first loop only)."""
    if ratio <= 0:
        return loop_count == 0
    return loop_count % ratio == 0
