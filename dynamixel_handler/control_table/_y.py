"""DYNAMIXEL-Y facts: the twelve YM070-210-* and YM080-230-* models (model numbers 4000-4170).

Addresses and sizes come from the ``ym*.model`` files of the ``dynamixel-sdk`` wheel (all twelve
carry the same table); everything else from the models' ROBOTIS e-Manual pages
(docs/en/dxl/y/ym070-210-m001-rh ... ym080-230-a099-rh and their shared control-table sections):

* Position: 524,288 pulses per output turn (±262,144 = ±180°, the SDK files' type info); the
  Electronic Gear Ratio (96/100, factory 1, 51 or 99 as the reducer) makes every position and
  velocity item count at the output. The Goal Position section's "approx. 0.006866 deg" per
  pulse is ten times 360/524,288 and does not match the resolution it states; not followed.
* Velocity 0.01 rev/min, acceleration 10 rev/min², current 0.01 A, PWM 0.1 %, Present Input
  Voltage 0.01 V but the voltage limits 0.1 V, temperatures 1 °C, Return Delay Time 2 µs.
* Bus Watchdog (8, 2 bytes, RAM) counts 20 ms (the manual's example: 100 = 2,000 ms) and reads
  -1 once tripped, as on X; Status Return Level (15) and Registered Instruction (16) are RAM
  below the first RAM address 512, and so are Controller State (152), Error Code (153), its
  history (154-169) and Hybrid Save (170). Gains and profiles (212-255) are the "Hybrid" area:
  writable with torque on (RAM-like) and stored when torque is off.
* Operating Mode: 0 current, 1 velocity, 3 position (the values X uses); Startup Configuration
  (34) has bit 0 (torque on at boot) only; Baud Rate (Bus) (12): 0..9 as on P (9 = 10.5 Mbps).
* Moving Threshold (48) is labelled "5 [pulse/ms]" in the table and "1 [Pulse]" in its section,
  but the section compares it with Present Velocity, and its factory values scale with the
  reducer as the velocity limits do (1,000 on -M001, 19 on -051, 10 on -099): read here as a
  velocity in 0.01 rev/min, as on X and P.
* Canonical names: "Baud Rate (Bus)" is ``baud_rate``, the motor's temperature and its limit are
  ``present_temperature`` and ``temperature_limit`` (the inverter's keep their own names),
  "Error Code" is ``error_code``.
"""
from __future__ import annotations

from typing import Dict, FrozenSet, Mapping, Tuple

from ._facts import SIGNED_ITEMS

SDK_FILES: Mapping[int, Tuple[str, str]] = {
    4000: ("YM070-210-M001-RH", "ym070_210_m001.model"),
    4010: ("YM070-210-B001-RH", "ym070_210_b001.model"),
    4020: ("YM070-210-R051-RH", "ym070_210_r051.model"),
    4030: ("YM070-210-R099-RH", "ym070_210_r099.model"),
    4040: ("YM070-210-A051-RH", "ym070_210_a051.model"),
    4050: ("YM070-210-A099-RH", "ym070_210_a099.model"),
    4120: ("YM080-230-M001-RH", "ym080_230_m001.model"),
    4130: ("YM080-230-B001-RH", "ym080_230_b001.model"),
    4140: ("YM080-230-R051-RH", "ym080_230_r051.model"),
    4150: ("YM080-230-R099-RH", "ym080_230_r099.model"),
    4160: ("YM080-230-A051-RH", "ym080_230_a051.model"),
    4170: ("YM080-230-A099-RH", "ym080_230_a099.model"),
}

#: SDK row names (canonical_name of them) -> the product's canonical name
RENAMED: Mapping[str, str] = {
    "baud_rate_bus": "baud_rate",
    "motor_temperature_limit": "temperature_limit",
    "present_motor_temperature": "present_temperature",
}
#: items below the first RAM address that are RAM (or Hybrid: writable with torque on)
RAM_BELOW_512: FrozenSet[str] = frozenset({
    "bus_watchdog", "status_return_level", "registered_instruction", "controller_state", "error_code",
    "hybrid_save", "velocity_i_gain", "velocity_p_gain", "velocity_ff_gain", "position_d_gain",
    "position_i_gain", "position_p_gain", "position_ff_gain", "profile_acceleration", "profile_velocity",
    "profile_acceleration_time", "profile_time", *(f"error_code_history_{n}" for n in range(1, 17)),
})
EEPROM_END = 512
#: the Hybrid area: written like RAM with torque on, stored in non-volatile memory when written with
#: torque off ("Hybrid Save(170)"), so an equal value is not written again
HYBRID: FrozenSet[str] = frozenset({
    "velocity_i_gain", "velocity_p_gain", "velocity_ff_gain", "position_d_gain", "position_i_gain",
    "position_p_gain", "position_ff_gain", "profile_acceleration", "profile_velocity",
    "profile_acceleration_time", "profile_time",
})
SIGNED: FrozenSet[str] = frozenset({"pwm_offset", "current_offset", "velocity_offset"})

HALF_TURN = 262_144
VELOCITY_RPM = 0.01
ACCELERATION_RPM2 = 10.0
CURRENT_MA = 10.0
PWM_FULL_SCALE = 1000
#: unit per pulse where an item differs from its quantity's scale
ITEM_SCALES: Mapping[str, float] = {"present_input_voltage": 0.01}
BAUD_RATES: Mapping[int, int] = {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000,
                                 6: 4_000_000, 7: 4_500_000, 8: 6_000_000, 9: 10_500_000}
OPERATING_MODES: Tuple[int, ...] = (0, 1, 3)
#: Indirect Address 1-128 at 256, Indirect Data 1-128 at 634; an entry may point at 0..919
INDIRECT: Tuple[Tuple[int, int, int], ...] = ((256, 634, 128),)
INDIRECT_TARGETS = (0, 919)
TABLE_SIZE = 920


def _factory(thresholds: int, motor_temp: int, accel: int, velocity: int, gear: int, brake: bool) -> Dict[str, int]:
    """One page's initial values: what differs between models, then what all twelve share."""
    values = {
        "in_position_threshold": thresholds, "moving_threshold": thresholds,
        "temperature_limit": motor_temp, "acceleration_limit": accel, "profile_acceleration": accel,
        "velocity_limit": velocity, "profile_velocity": velocity,
        "electronic_gearratio_numerator": gear, "electronic_gearratio_denominator": 1,
        # the brake models (-B001, -A0xx): Brake Delay, Goal Update Delay, excitation
        "brake_delay": 20 if brake else 0, "goal_update_delay": 200 if brake else 0,
        "normal_excitation_voltage": 30 if brake else 0, "overexcitation_time": 200 if brake else 0,
    }
    values.update({
        "inverter_temperature_limit": 80, "max_voltage_limit": 320, "min_voltage_limit": 160, "pwm_limit": 1000,
        "current_limit": 2080, "max_position_limit": HALF_TURN, "min_position_limit": -HALF_TURN,
        "position_limit_threshold": 0, "following_error_threshold": 0, "safe_stop_time": 200,
        "overexcitation_voltage": 100, "velocity_i_gain": 2_446_559, "velocity_p_gain": 24_778,
        "velocity_ff_gain": 0, "position_d_gain": 9_090, "position_i_gain": 0, "position_p_gain": 6_283_185,
        "position_ff_gain": 0, "profile_acceleration_time": 400, "profile_time": 800, "hybrid_save": 0,
        "error_code": 0, "controller_state": 2,
    })
    return values


#: model number -> factory values (e-Manual "Default" column of each page)
FACTORY: Mapping[int, Mapping[str, int]] = {
    4000: _factory(1000, 80, 44_000, 550_000, 1, False),   # y/ym070-210-m001-rh
    4010: _factory(1000, 80, 44_000, 550_000, 1, True),    # y/ym070-210-b001-rh
    4020: _factory(19, 60, 313, 3_921, 51, False),         # y/ym070-210-r051-rh
    4030: _factory(10, 60, 161, 2_020, 99, False),         # y/ym070-210-r099-rh
    4040: _factory(19, 60, 313, 3_921, 51, True),          # y/ym070-210-a051-rh
    4050: _factory(10, 60, 161, 2_020, 99, True),          # y/ym070-210-a099-rh
    4120: _factory(1000, 80, 24_800, 310_000, 1, False),   # y/ym080-230-m001-rh
    4130: _factory(1000, 80, 24_800, 310_000, 1, True),    # y/ym080-230-b001-rh
    4140: _factory(19, 60, 313, 3_921, 51, False),         # y/ym080-230-r051-rh
    4150: _factory(10, 60, 161, 2_020, 99, False),         # y/ym080-230-r099-rh
    4160: _factory(19, 60, 313, 3_921, 51, True),          # y/ym080-230-a051-rh
    4170: _factory(10, 60, 161, 2_020, 99, True),          # y/ym080-230-a099-rh
}


def rows(sdk_rows: Mapping[str, Tuple[int, int]]) -> Dict[str, Tuple[int, int, bool, bool]]:
    """The SDK file's rows under the product's names: name -> (address, size, signed, eeprom)."""
    out = {}
    for sdk_name, (address, size) in sdk_rows.items():
        name = RENAMED.get(sdk_name, sdk_name)
        signed = name in SIGNED_ITEMS or name in SIGNED
        out[name] = (address, size, signed, address < EEPROM_END and name not in RAM_BELOW_512)
    return out
