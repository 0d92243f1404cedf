"""What the command messages mean: fields -> control-table items, modes per control topic,
shortcut names, the bounds of goals. ROS-free. The field <-> item tables of the state
groups are defined once, in ``groups``; the command side uses their inverse."""
from __future__ import annotations

from typing import Mapping

from ..control_table import MAX_ROTATION
from ..protocol import BROADCAST_ID
from ..servo.groups import GAIN, GOAL, LIMIT

#: control topic/field name -> operating mode it needs
CONTROL_MODES: Mapping[str, str] = {
    "pwm_control": "pwm", "current_control": "current", "velocity_control": "velocity",
    "position_control": "position", "extended_position_control": "ex_position",
    "current_base_position_control": "cur_position",
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
#: modes that need a current sensor (XL430 / XC430 / 2XL430 have none: Current Limit absent)
CURRENT_MODES = frozenset({"current", "cur_position"})

__all__ = ["BROADCAST_ID", "CONTROL_MODES", "CURRENT_MODES", "GAIN_FIELDS", "GOAL_FIELDS", "LIMIT_FIELDS",
           "MAGNITUDE_LIMIT", "MAX_ROTATION", "SHORTCUTS"]
