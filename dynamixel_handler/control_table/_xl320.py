"""The XL-320 (model number 350): a small Protocol 2.0 control table of its own.

Facts from the ROBOTIS e-Manual page of the XL-320 (emanual.robotis.com ``docs/en/dxl/x/xl320``,
control table, initial values and item descriptions); addresses and sizes from the
``xl320.model`` file of the ``dynamixel-sdk`` wheel, which agrees with that page:

* 2-byte items, 1-byte voltage and temperature items; EEPROM 0..18, RAM from 24.
* Goal / Present Position and CW / CCW Angle Limit: 0..1023 over 300 degrees ("0.29 deg" a
  unit; 512 is the middle). Our zero is 512, so 0 is -150 deg and 1023 +150 deg.
* Moving Speed (32): in Joint Mode the speed of a move, 0..1023 at about 0.111 rpm a unit (0:
  as fast as the motor goes); in Wheel Mode the speed and direction, 0..1023 one way (CCW) and
  1024..2047 the other (CW): bit 10 carries the direction, a sign-magnitude value. Present Speed
  (39) and Present Load (41, about 0.1 % a unit) use the same encoding. The e-Manual gives the
  wheel-mode unit as about 0.1 % of the output; we read every speed at 0.111 rpm a unit
  (1023 = 114 rpm, the no-load speed), so wheel speeds are in deg/s like every other servo's.
* Control Mode (11): 1 Wheel Mode (our "velocity"), 2 Joint Mode (our "position").
* Max Torque (15, EEPROM) and Torque Limit (35, RAM): 0..1023, about 0.1 % of the maximum
  output a unit; Torque Limit takes Max Torque's value at power on. No current sensing.
* LED (25): a colour, bits 0 red, 1 green, 2 blue (0..7).
* Baud Rate (4): 0 9600, 1 57600, 2 115200, 3 1 Mbps (factory 3).
* No Operating Mode values of the X series, no bus watchdog, no profile items, no PWM goal, no
  homing offset, no drive mode, no indirect addresses, no Protocol Type register.
* Shutdown (18) and Hardware Error Status (50): bit 0 overload, bit 1 overheating, bit 2 input
  voltage (another order than the X series').
"""

from __future__ import annotations

from typing import Dict, Mapping, Optional, Tuple

NUMBER = 350
NAME = "XL-320"
SDK_FILE = "xl320.model"

#: the SDK file's names -> our canonical names (the rest keep theirs)
RENAMED: Mapping[str, str] = {
    "cw_angle_limit": "min_position_limit",
    "ccw_angle_limit": "max_position_limit",
    "control_mode": "operating_mode",
    "max_torque": "pwm_limit",         # the limit of the output, in % (as PWM Limit on X)
    "moving_speed": "goal_velocity",
    "present_speed": "present_velocity",
    "present_voltage": "present_input_voltage",
    "led": "led_colour",               # 0..7 colour bits, not the X series' on/off LED
    "d_gain": "position_d_gain",
    "i_gain": "position_i_gain",
    "p_gain": "position_p_gain",
}

#: first RAM address (Torque Enable); the items below it are EEPROM
EEPROM_END = 24
#: sign-magnitude items and the bit that carries their direction (set: CW, negative)
DIRECTION_BIT = 10
SIGN_MAGNITUDE = frozenset({"goal_velocity", "present_velocity", "present_load"})
#: the registers' own ranges (e-Manual "Min"/"Max" columns) where narrower than their bytes
RANGES: Mapping[str, Tuple[int, int]] = {
    "goal_position": (0, 1023), "present_position": (0, 1023),
    "min_position_limit": (0, 1023), "max_position_limit": (0, 1023),
    "pwm_limit": (0, 1023), "torque_limit": (0, 1023), "punch": (0, 1023),
    "temperature_limit": (0, 150), "min_voltage_limit": (50, 250), "max_voltage_limit": (50, 250),
    "position_d_gain": (0, 254), "position_i_gain": (0, 254), "position_p_gain": (0, 254),
    "led_colour": (0, 7), "shutdown": (0, 7), "return_delay_time": (0, 254),
}

#: Control Mode values by our mode names
MODE_VALUES: Mapping[str, int] = {"velocity": 1, "position": 2}
BAUD_RATES: Mapping[int, int] = {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000}
TABLE_SIZE = 53  # Punch (51, 2 bytes) is the last item

POSITION_DEG_PER_PULSE = 300.0 / 1023.0
POSITION_ZERO_PULSE = 512
VELOCITY_RPM = 0.111
OUTPUT_FULL_SCALE = 1023  # Max Torque / Torque Limit: 1023 = 100 %

#: factory (initial) values of the e-Manual's control table; Torque Limit takes Max Torque's
FACTORY: Mapping[str, int] = {
    "baud_rate": 3, "return_delay_time": 250, "min_position_limit": 0, "max_position_limit": 1023,
    "operating_mode": 2, "temperature_limit": 65, "min_voltage_limit": 60, "max_voltage_limit": 90,
    "pwm_limit": 1023, "status_return_level": 2, "shutdown": 3, "torque_enable": 0, "led_colour": 0,
    "position_d_gain": 0, "position_i_gain": 0, "position_p_gain": 32, "torque_limit": 1023,
    "registered_instruction": 0, "moving": 0, "hardware_error_status": 0, "punch": 32,
}

#: EEPROM item -> the RAM item the servo copies it into at power on (Torque Limit := Max Torque)
RAM_COPIES: Mapping[str, str] = {"pwm_limit": "torque_limit"}

#: Hardware Error Status / Shutdown bits: cause -> bit
ERROR_BITS: Mapping[str, int] = {"overload": 0, "overheating": 1, "input_voltage": 2}


def rows(sdk_rows: Mapping[str, Tuple[int, int]]) -> Dict[str, Tuple[int, int, int, Optional[Tuple[int, int]]]]:
    """The items from the SDK file's rows: canonical name -> (address, size, direction bit, range)."""
    out: Dict[str, Tuple[int, int, int, Optional[Tuple[int, int]]]] = {}
    for sdk_name, (address, size) in sdk_rows.items():
        name = RENAMED.get(sdk_name, sdk_name)
        out[name] = (address, size, DIRECTION_BIT if name in SIGN_MAGNITUDE else 0, RANGES.get(name))
    return out
