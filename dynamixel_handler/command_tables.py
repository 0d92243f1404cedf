"""What the command messages mean: fields -> control-table items, modes per control topic and
series, shortcut names, the bounds of goals. ROS-free. The field <-> item tables of the state
groups are defined once, in ``groups``; the command side uses their inverse."""
from __future__ import annotations

from typing import Mapping

from .control_table import OPERATING_MODES
from .groups import GAIN, GOAL, LIMIT
from .protocol import BROADCAST_ID

#: control topic/field name -> operating mode it needs
CONTROL_MODES: Mapping[str, str] = {
    "pwm_control": "pwm", "current_control": "current", "velocity_control": "velocity",
    "position_control": "position", "extended_position_control": "ex_position",
    "current_base_position_control": "cur_position",
}
#: modes each series offers
SERIES_MODES: Mapping[str, frozenset[str]] = {
    "X": frozenset(OPERATING_MODES), "P": frozenset(OPERATING_MODES) - {"cur_position"},
    "PRO": frozenset({"current", "velocity", "position", "ex_position"}),
}
#: goal-like message field -> control-table item (``acceleration_deg_ss``: the control topics' name
#: of the profile acceleration)
GOAL_FIELDS: Mapping[str, str] = {**{f: i for i, f in GOAL.items()}, "acceleration_deg_ss": "profile_acceleration"}
LIMIT_FIELDS: Mapping[str, str] = {f: i for i, f in LIMIT.items()}
GAIN_FIELDS: Mapping[str, str] = {f: i for i, f in GAIN.items()}
#: item -> the limit item its magnitude may not exceed
MAGNITUDE_LIMIT: Mapping[str, str] = {
    "goal_current": "current_limit", "goal_velocity": "velocity_limit", "goal_pwm": "pwm_limit",
    "profile_velocity": "velocity_limit", "profile_acceleration": "acceleration_limit",
}
#: shortcut command (long and short name) -> action
SHORTCUTS: Mapping[str, str] = {
    "clear_error": "clear_error", "CE": "clear_error", "torque_on": "torque_on", "TON": "torque_on",
    "torque_off": "torque_off", "TOFF": "torque_off", "add_id": "add_id", "ADID": "add_id",
    "remove_id": "remove_id", "RMID": "remove_id", "reset_offset": "reset_offset", "enable": "enable",
    "disable": "disable", "reboot": "reboot",
}
#: turns a goal may hold (rotation field; Pro and P goals are bounded to as many turns)
MAX_ROTATION = 256.0
#: X series: Profile Velocity and Profile Acceleration registers take 0..32767 (e-Manual); on the
#: P series they are bounded by Velocity Limit and Acceleration Limit instead
X_PROFILE_MAX = 32767
#: modes that need a current sensor (XL430 / XC430 / 2XL430 have none: Current Limit absent)
CURRENT_MODES = frozenset({"current", "cur_position"})
#: X multi-turn goals: -1,048,575..1,048,575 pulses (±256 turns) in the e-Manual
X_MULTI_TURN_GOAL = 1_048_575

__all__ = ["BROADCAST_ID", "CONTROL_MODES", "CURRENT_MODES", "GAIN_FIELDS", "GOAL_FIELDS", "LIMIT_FIELDS",
           "MAGNITUDE_LIMIT", "MAX_ROTATION", "SERIES_MODES", "SHORTCUTS", "X_MULTI_TURN_GOAL", "X_PROFILE_MAX"]
