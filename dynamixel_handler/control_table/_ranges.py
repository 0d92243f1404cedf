"""The values each model's e-Manual allows in its registers: model number -> item -> (lowest, highest),
raw register values. The set-up tool refuses a value outside, the virtual bus answers it with a Data
Range Error; both read these through ``Model.value_range``.

Source: the ROBOTIS e-Manual (github.com/ROBOTIS-GIT/emanual), the "Range" column of each model's
control table (``docs/en/dxl/x/<model>.md``, ``docs/en/dxl/p/<model>.md``, ``docs/en/dxl/pro/<model>.md``,
``docs/en/dxl/y/<model>.md``, ``docs/en/platform/rh_p12_rn/<page>.md``) and, where a page has no such
column, the value range its item sections give, mostly from the sections it includes
(``_includes/en/dxl/control_table_*.md``: ``id``, ``return_delay_time``, ``shadowid``, ``buswatchdog``,
``homingoffset``, ``movingthreshold``, ``temp_limit_2``, ``volt_limit_2``, ``pwm_limit``, ``acclimit``,
``vellimit``, ``velocity_pi_gain``, ``position_pid_gain``, ``status_return_lv``, ``torque_enable_2``; the
old PRO "-R" table's ``*_pro`` sections; the P sections ``_includes/en/dxl/p/control_table_*.md``).
``scripts/emanual_ranges.py`` prints these columns from a checkout of that repository. The pages read:

* X: xm430-w350, xm430-w210, xh430-w350, xh430-w210, xh430-v350, xh430-v210, xd430-t350, xd430-t210,
  xl430-w250, xc430-w150, xc430-w240, 2xl430-w250, 2xc430-w250, xw430-t333, xw430-t200, xh540-w270,
  xh540-w150, xd540-t270, xm540-w270, xm540-w150, xh540-v270, xh540-v150, xw540-t260, xw540-t140,
  xw540-h260, xl330-m077, xl330-m288, xc330-t181, xc330-t288, xc330-m181, xc330-m288, xm335-t323;
* MX (2.0): mx-28-2; P: ph42-020-s300-r, ph54-100-s500-r, ph54-200-s500-r, pm42-010-s260-r,
  pm54-040-s250-r, pm54-060-s250-r; PRO: h54-200-s500-ra, h54-200-s500-r (the old "-R" table);
  Y: ym070-210-m001-rh; XL-320: xl320;
* grippers (``platform/rh_p12_rn/``): rh_p12_rn (RH-P12-RN, its item sections and the ``*_pro``
  sections it includes; commit 089162d6f19f, the newer of the two stored revisions, which give the same
  ranges as 54d84a1c6fde), rh-p12-rna (RH-P12-RN(A), its Range column and the P sections it includes;
  commit 09a8c52bd870, the newer of the two stored revisions, against fee860d7aaf9).

Where the pages disagree with themselves, and what is kept:

* Voltage limits: the XM430-W350 table gives both limits "110 ~ 300" (the 24 V models' range) while
  its Default is 95 and the section it includes says 95 ~ 160, as the XM430-W210 table does: 95 ~ 160
  is kept. The X330 and XM335 tables give 31 ~ 70 (5 V) and 55 ~ 140 (12 V) but include the 12 V X430
  section (95 ~ 160): the tables, which hold their defaults, are kept.
* Velocity Limit: the X330 and XM335 tables give 0 ~ 2,047 and include the X430 section (0 ~ 1,023):
  the tables are kept.
* ID: some X tables (XM430-W350, XH430-W350, XH430-V350, XC430, 2XL430, 2XC430, XH540-W150, XH540-V270,
  XH540-V150) give 0 ~ 253, the others and the ID section 0 ~ 252 (254 is broadcast): 0 ~ 252. The
  grippers' specification tables and the RH-P12-RN(A) table give 0 ~ 252, while the ID section the
  RH-P12-RN includes (``control_table_id``) and the newest stored P ID section (``p/control_table_7_id``,
  0 ~ 252 in an older revision) say 0 ~ 253: 0 ~ 252.
* Secondary ID: the X tables give 0 ~ 252, yet their Default is 255 and the section says 253 ~ 255
  switch it off; the P tables (and the RH-P12-RN(A) one) give 0 ~ 255: 0 ~ 255.
* Bus Watchdog: the X tables give 1 ~ 127 with a Default of 0; the section gives 0 (off) and 1 ~ 127:
  0 ~ 127 (its -1 is an error the servo sets, not a value to write). The RH-P12-RN(A) table gives
  0 ~ 127, as the P section it includes.
* Return Delay Time: the H54-200-S500-R(A) and RH-P12-RN(A) tables give 0 ~ 255, the sections they
  include 0 ~ 254 (as every other table): 0 ~ 254.
* Voltage limits of the RH-P12-RN(A): its table and the P section it includes (which names the
  gripper) give both limits 150 ~ 300, yet the table's Max Voltage Limit Default is 350; the older
  revision (fee860d7aaf9) gave 0 ~ 350, the P section 150 ~ 350 to the other P models: 150 ~ 350 is
  kept, the newest lowest bound with the highest that holds the Default.
* Velocity Limit of the RH-P12-RN: its section gives 0 ~ 2,147,483,647 while its Present Velocity
  section says -1,023 ~ 1,023 are used: the Velocity Limit section is kept.
* Protocol Type: "1 ~ 2" on X430/X540, "2 ~ 22" on X330/XM335, "2, 10" on P, "2" on Y; a list is kept
  as its lowest .. highest (the set-up tool writes 2 only). So is the RH-P12-RN's External Port Mode,
  a list of the modes 0 ~ 3 without a range column.
* Profile Acceleration / Velocity on P, Y and the RH-P12-RN(A), and the RH-P12-RN's Goal Acceleration:
  "0 ~ Acceleration (Velocity) Limit": kept as 0 .. the highest that limit takes (the servo bounds it
  by the limit's present value).
* XD430-T350 and XD430-T210 tables give the Model Number of the XH430 they equal (1,000 and 1,010),
  the XW430-T200 table has its columns shifted by one, the Y table sizes of Inverter Temperature Limit
  and Min Voltage Limit (4) disagree with their addresses; the sections the RH-P12-RN includes name
  other models' addresses (Max / Min Voltage Limit 36 / 40, Torque Enable 64), the RH-P12-RN(A) page
  once names Profile Velocity at 562 and Goal PWM at 584; the ranges themselves are unaffected.
* Revisions: the PH54-200-S500-R page has had an Acceleration Limit Default of 9,982 and of
  3,992,644; both revisions give the range 0 ~ 3,992,644. The RH-P12-RN(A) page has had a Moving
  Threshold Default of 50 (fee860d7aaf9) and of 80, the range 0 ~ 2,970 in both; the older one also
  had Drive Mode (10, 0 ~ 1), which the newer one no longer lists.

Inferred, not read on a page of its own (said at each entry): XD540-T150 (the XD pages say their
tables equal the XH ones: XH540-W150's), XC335-T332 (no page: XC330-T288's, as its factory values),
the PRO "-R(A)" models other than H54-200-S500-R(A) (that page equals PH54-200-S500-R's but for the
Return Delay Time, so each takes its P twin's), MX-64/106(2.0) (MX-28(2.0)'s sections, Current Limit
0 .. its Default as on every X table), the L series and the other old PRO "-R" models (the H54-200-S500-R
table is the one they share), the Y models other than YM070-210-M001-RH (the twelve share one table:
the items whose Default is the same on all twelve).

Missing on the pages (the register's byte range is kept, ``Model.byte_range_items`` names them): the
old PRO "-R" Homing Offset, Goal Acceleration (``profile_acceleration``) and External Port Mode; the
RH-P12-RN(A)'s Protocol Type (its SDK file has it at 13, its page lists no such item); the Velocity and
Acceleration Limits and the profiles of the Y models other than YM070-210-M001-RH. The XL-320's ranges
beyond ID, Status Return Level and Torque Enable are its items' own (``_xl320.RANGES``, the same page's
Min/Max columns).
"""

from __future__ import annotations

from typing import Dict, Mapping, Optional, Tuple

Range = Tuple[int, int]
Ranges = Dict[str, Range]

#: the items whose range every model has (e-Manual, or the register's bytes where the manual gives none)
LISTED: Tuple[str, ...] = (
    "id", "return_delay_time", "secondary_id", "protocol_type", "homing_offset", "moving_threshold",
    "temperature_limit", "max_voltage_limit", "min_voltage_limit", "pwm_limit", "current_limit",
    "acceleration_limit", "velocity_limit", "startup_configuration", "torque_enable", "led",
    "status_return_level", "bus_watchdog", "velocity_i_gain", "velocity_p_gain", "position_d_gain",
    "position_i_gain", "position_p_gain", "feedforward_2nd_gain", "feedforward_1st_gain",
    "velocity_ff_gain", "position_ff_gain", "profile_acceleration", "profile_velocity",
    "external_port_mode_1", "external_port_mode_2", "external_port_mode_3", "external_port_mode_4",
)

_I32 = (-(1 << 31), (1 << 31) - 1)
_I32_TOP = (1 << 31) - 1
_X_GAINS = ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain", "position_p_gain",
            "feedforward_2nd_gain", "feedforward_1st_gain")
_PORTS = tuple(f"external_port_mode_{n}" for n in (1, 2, 3, 4))

# the shared sections: ID 0 ~ 252, Return Delay Time 0 ~ 254, Secondary ID 0 ~ 252 on and 253 ~ 255
# off, Status Return Level 0 ~ 2, Torque Enable 0 ~ 1
_ANY: Ranges = {"id": (0, 252), "return_delay_time": (0, 254), "status_return_level": (0, 2), "torque_enable": (0, 1)}

# X430 / X540 / X330 / XM335 tables (and the MX(2.0) pages' sections)
_X_TABLE: Ranges = {
    **_ANY, "secondary_id": (0, 255), "protocol_type": (1, 2), "homing_offset": (-1_044_479, 1_044_479),
    "moving_threshold": (0, 1023), "temperature_limit": (0, 100), "pwm_limit": (0, 885),
    "acceleration_limit": (0, 32767), "startup_configuration": (0, 3), "led": (0, 1), "bus_watchdog": (0, 127),
    **{gain: (0, 16383) for gain in _X_GAINS},
    "profile_acceleration": (0, 32767), "profile_velocity": (0, 32767), **{port: (0, 3) for port in _PORTS},
}
_V12 = (95, 160)
_V24 = (110, 300)
_V_XL = (60, 140)   # XL430-W250, 2XL430-W250
_V_XC = (60, 160)   # XC430, 2XC430
_V330_5 = (31, 70)
_V330_12 = (55, 140)


def _x(volts: Range, current: Optional[int], velocity: int = 1023, **extra: Range) -> Ranges:
    """An X table: its voltage limits, Current Limit 0 .. ``current`` (None: no such item), Velocity Limit."""
    ranges = {**_X_TABLE, "max_voltage_limit": volts, "min_voltage_limit": volts, "velocity_limit": (0, velocity)}
    if current is not None:
        ranges["current_limit"] = (0, current)
    ranges.update(extra)
    return ranges


def _x330(volts: Range, current: int) -> Ranges:
    """An X330 / XM335 table: Velocity Limit 0 ~ 2,047, Protocol Type 2 ~ 22, PWM Slope 1 ~ 255."""
    return _x(volts, current, 2047, protocol_type=(2, 22), pwm_slope=(1, 255))


# P tables (and the PRO "-R(A)" ones)
_P_TABLE: Ranges = {
    **_ANY, "secondary_id": (0, 255), "protocol_type": (2, 10), "homing_offset": _I32, "temperature_limit": (0, 100),
    "max_voltage_limit": (150, 350), "min_voltage_limit": (150, 350), "pwm_limit": (0, 2009),
    "startup_configuration": (0, 3), "bus_watchdog": (0, 127), **{gain: (0, 32767) for gain in _X_GAINS},
    **{port: (0, 3) for port in _PORTS},
}


def _p(velocity: int, current: int, acceleration: int) -> Ranges:
    """A P table: Velocity Limit and Moving Threshold 0 .. ``velocity``, Current Limit, Acceleration Limit;
    the profiles 0 .. the limit they are bounded by."""
    return {**_P_TABLE, "moving_threshold": (0, velocity), "velocity_limit": (0, velocity),
            "current_limit": (0, current), "acceleration_limit": (0, acceleration),
            "profile_acceleration": (0, acceleration), "profile_velocity": (0, velocity)}


_PH42_020 = _p(2920, 4500, 4_306_173)
_PH54_100 = _p(2920, 15900, 4_255_632)
_PH54_200 = _p(2900, 22740, 3_992_644)
_PM42_010 = _p(2600, 1461, 4_346_756)
_PM54_040 = _p(2840, 4470, 4_414_976)
_PM54_060 = _p(2830, 7980, 4_457_932)

# old PRO "-R" table (pro/h54-200-s500-r and the sections it includes; its Status Return Level and Torque
# Enable sections are the ones the X tables give 0 ~ 2 and 0 ~ 1 with): Min/Max Voltage Limit 0 ~ 400,
# Acceleration / Velocity Limit and Moving Threshold 0 ~ 2,147,483,647, Torque Limit 0 ~ 32,767, the
# Velocity PI and Position P Gains 0 ~ 32,767; Homing Offset, Goal Acceleration and External Port
# Mode are given no range
_OLD_PRO: Ranges = {
    **_ANY, "temperature_limit": (0, 100), "max_voltage_limit": (0, 400), "min_voltage_limit": (0, 400),
    "acceleration_limit": (0, _I32_TOP), "velocity_limit": (0, _I32_TOP), "moving_threshold": (0, _I32_TOP),
    "current_limit": (0, 32767), "velocity_i_gain": (0, 32767), "velocity_p_gain": (0, 32767),
    "position_p_gain": (0, 32767),
}

# Y table (y/ym070-210-m001-rh): what all twelve share (their Defaults are the same) ...
_Y_TABLE: Ranges = {
    **_ANY, "secondary_id": (0, 252), "protocol_type": (2, 2), "bus_watchdog": (0, 127), "startup_configuration": (0, 1),
    "moving_threshold": (0, _I32_TOP), "homing_offset": (-_I32_TOP, _I32_TOP), "inverter_temperature_limit": (0, 100),
    "temperature_limit": (0, 100), "max_voltage_limit": (240, 400), "min_voltage_limit": (160, 400),
    "pwm_limit": (0, 1000), "current_limit": (0, 2080), "led": (0, 1),
    **{gain: (0, _I32_TOP) for gain in ("velocity_i_gain", "velocity_p_gain", "velocity_ff_gain", "position_d_gain",
                                         "position_i_gain", "position_p_gain", "position_ff_gain")},
}
# ... and what scales with the reducer (this page only)
_YM070_M001: Ranges = {**_Y_TABLE, "acceleration_limit": (0, 38_520_000), "velocity_limit": (0, 642_200),
                       "profile_acceleration": (0, 38_520_000), "profile_velocity": (0, 642_200)}

# RH-P12-RN(A) (platform/rh_p12_rn/rh-p12-rna, commit 09a8c52bd870; the Range column and the P sections):
# Homing Offset 0 ~ 1,150 (its stroke), Moving Threshold and Velocity Limit 0 ~ 2,970, Current Limit
# 0 ~ 1,984, Acceleration Limit 0 ~ 1,378,788, PWM Limit 0 ~ 2,009, the seven gains 0 ~ 32,767; no
# Protocol Type (its byte range is kept); voltage limits: see above
_RH_P12_RN_A: Ranges = {
    **_ANY, "secondary_id": (0, 255), "homing_offset": (0, 1150), "moving_threshold": (0, 2970),
    "temperature_limit": (0, 100), "max_voltage_limit": (150, 350), "min_voltage_limit": (150, 350),
    "pwm_limit": (0, 2009), "current_limit": (0, 1984), "acceleration_limit": (0, 1_378_788),
    "velocity_limit": (0, 2970), "bus_watchdog": (0, 127), **{gain: (0, 32767) for gain in _X_GAINS},
    **{port: (0, 3) for port in _PORTS}, "profile_acceleration": (0, 1_378_788), "profile_velocity": (0, 2970),
}

# RH-P12-RN (platform/rh_p12_rn/rh_p12_rn, commit 089162d6f19f; its item sections and the ``*_pro`` ones
# it includes): Moving Threshold, Acceleration and Velocity Limit 0 ~ 2,147,483,647, Min/Max Voltage
# Limit 0 ~ 400, Current Limit 0 ~ 820, the Position PID Gains 0 ~ 32,767, External Port Mode 0 ~ 3,
# Goal Acceleration (``profile_acceleration``) 0 ~ Acceleration Limit
_RH_P12_RN: Ranges = {
    **_ANY, "moving_threshold": (0, _I32_TOP), "temperature_limit": (0, 100), "max_voltage_limit": (0, 400),
    "min_voltage_limit": (0, 400), "acceleration_limit": (0, _I32_TOP), "current_limit": (0, 820),
    "velocity_limit": (0, _I32_TOP), **{port: (0, 3) for port in _PORTS},
    **{gain: (0, 32767) for gain in ("position_d_gain", "position_i_gain", "position_p_gain")},
    "profile_acceleration": (0, _I32_TOP),
}

# Model number -> its e-Manual ranges; the comment names the page (docs/en/dxl/..., docs/en/platform/...).
RANGES: Mapping[int, Ranges] = {
    # ---- MX (2.0): the X sections (mx/mx-28-2); current limit 0 .. its Default, as every X table --------
    30: _x(_V12, None),                                 # mx/mx-28-2
    311: _x(_V12, 1941),                                # mx/mx-64-2: inferred (MX-28(2.0)'s sections)
    321: _x(_V12, 2047),                                # mx/mx-106-2: inferred (MX-28(2.0)'s sections)
    # ---- X430 ---------------------------------------------------------------------------------------
    1000: _x(_V12, 648),                                # x/xh430-w350
    1001: _x(_V12, 648),                                # x/xd430-t350
    1010: _x(_V12, 648),                                # x/xh430-w210
    1011: _x(_V12, 648),                                # x/xd430-t210
    1020: _x(_V12, 1193),                               # x/xm430-w350 (voltage: see above)
    1030: _x(_V12, 1193),                               # x/xm430-w210
    1040: _x(_V24, 689),                                # x/xh430-v350
    1050: _x(_V24, 689),                                # x/xh430-v210 (its sections)
    1060: _x(_V_XL, None),                              # x/xl430-w250 (its sections)
    1070: _x(_V_XC, None),                              # x/xc430-w150
    1080: _x(_V_XC, None),                              # x/xc430-w240
    1090: _x(_V_XL, None),                              # x/2xl430-w250
    1160: _x(_V_XC, None),                              # x/2xc430-w250
    1270: _x(_V12, 2047),                               # x/xw430-t333
    1280: _x(_V12, 2047),                               # x/xw430-t200
    # ---- X540 ---------------------------------------------------------------------------------------
    1100: _x(_V12, 2047),                               # x/xh540-w270
    1101: _x(_V12, 2047),                               # x/xd540-t270
    1110: _x(_V12, 2047),                               # x/xh540-w150
    1111: _x(_V12, 2047),                               # x/xd540-t150: inferred (= XH540-W150, as the XD pages say)
    1120: _x(_V12, 2047),                               # x/xm540-w270
    1130: _x(_V12, 2047),                               # x/xm540-w150 (its sections)
    1140: _x(_V24, 2047),                               # x/xh540-v270
    1150: _x(_V24, 2047),                               # x/xh540-v150
    1170: _x(_V12, 2047),                               # x/xw540-t260
    1180: _x(_V12, 2047),                               # x/xw540-t140
    1310: _x(_V24, 1188),                               # x/xw540-h260
    # ---- X330, XM335 --------------------------------------------------------------------------------
    1190: _x330(_V330_5, 1750),                         # x/xl330-m077
    1200: _x330(_V330_5, 1750),                         # x/xl330-m288
    1210: _x330(_V330_12, 910),                         # x/xc330-t181
    1220: _x330(_V330_12, 910),                         # x/xc330-t288
    1230: _x330(_V330_5, 2352),                         # x/xc330-m181
    1240: _x330(_V330_5, 2352),                         # x/xc330-m288
    1710: _x330(_V330_12, 910),                         # x/xm335-t323
    1700: _x330(_V330_12, 910),                         # XC335-T332: inferred (no page; XC330-T288's)
    # ---- P ------------------------------------------------------------------------------------------
    2000: _PH42_020,                                    # p/ph42-020-s300-r
    2010: _PH54_100,                                    # p/ph54-100-s500-r
    2020: _PH54_200,                                    # p/ph54-200-s500-r
    2100: _PM42_010,                                    # p/pm42-010-s260-r
    2110: _PM54_040,                                    # p/pm54-040-s250-r
    2120: _PM54_060,                                    # p/pm54-060-s250-r
    # ---- PRO "-R(A)": the P twin's table (read: H54-200-S500-R(A) = PH54-200-S500-R) ----------------
    54025: _PH54_200,                                   # pro/h54-200-s500-ra
    43289: _PM42_010,                                   # pro/m42-10-s260-ra: inferred (PM42-010-S260-R's)
    46097: _PM54_040,                                   # pro/m54-40-s250-ra: inferred (PM54-040-S250-R's)
    46353: _PM54_060,                                   # pro/m54-60-s250-ra: inferred (PM54-060-S250-R's)
    51201: _PH42_020,                                   # pro/h42-20-s300-ra: inferred (PH42-020-S300-R's)
    53769: _PH54_100,                                   # pro/h54-100-s500-ra: inferred (PH54-100-S500-R's)
    # ---- grippers (docs/en/platform/rh_p12_rn/...) ----------------------------------------------------
    35074: _RH_P12_RN_A,                                # rh-p12-rna (commit 09a8c52bd870)
    35073: _RH_P12_RN,                                  # rh_p12_rn (commit 089162d6f19f)
    # ---- old PRO "-R": the H54-200-S500-R table; its siblings and the L series inferred (shared table) -
    54024: _OLD_PRO,                                    # pro/h54-200-s500-r
    **{number: _OLD_PRO for number in (43288, 46096, 46352, 51200, 53768, 37896, 37928, 38152, 38176, 35072)},
    # ---- XL-320 (x/xl320, its Min/Max columns): the rest are its items' own ranges (``_xl320.RANGES``) ---
    350: {"id": (0, 252), "status_return_level": (0, 2), "torque_enable": (0, 1)},
    # ---- Y ------------------------------------------------------------------------------------------
    4000: _YM070_M001,                                  # y/ym070-210-m001-rh
    **{number: _Y_TABLE for number in (4010, 4020, 4030, 4040, 4050, 4120, 4130, 4140, 4150, 4160, 4170)},
}


def ranges_of(number: int) -> Ranges:
    """The e-Manual ranges of model ``number`` (empty where none were read: the XL-320's are its items')."""
    return dict(RANGES.get(number, {}))
