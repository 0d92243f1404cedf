"""Per-model facts the SDK ``.model`` files do not carry (sources: ROBOTIS e-Manual pages).

* Unit scales per model: current mA per LSB, velocity rpm per LSB, acceleration rev/min^2 per LSB,
  PWM full scale, position pulses per half revolution (P / Pro).
* Items the SDK files omit but the e-Manual lists.
* The whole control table of the old DYNAMIXEL PRO "-R" firmware (model numbers 43288 ... 54024),
  which is not in the SDK files at all.

Old PRO facts, from the e-Manual pages of H54-200-S500-R, H54-100-S500-R, H42-20-S300-R,
M54-60-S250-R, M54-40-S250-R and M42-10-S260-R:

* Velocity items count motor rpm before the gear head; the output scale per LSB is 1/gear ratio
  rpm: 0.00199234 (H54), 0.00329218 (H42), 0.00397746 (M54), 0.00389076 (M42).
* Goal Acceleration (606) and Acceleration Limit (26) are labelled "58,000 [rev/min^2]" and the
  item text says "58,000 RPM^2 @ Core Motor", i.e. per LSB the *motor* accelerates by
  58,000 rev/min^2, so the output accelerates by 58,000 / gear ratio = 58,000 * rpm scale
  rev/min^2 (about 115.6 rev/min^2 = 11.56 deg/s^2 per LSB on H54). Our shared notes quote a
  third-party reading of 58,000 / resolution (pulses per revolution), which is 1000 times
  smaller on H54 (501,923 pulses vs gear ratio 501.923); we follow the manual's wording.
* Current: mA = value * 33,000 / 2,048 (54 class) or value * 8,250 / 2,048 (42 class); the same
  formula holds for Goal Torque (604), Torque Limit (30) and Present Current (621).
* Position: H54 +-250,961, H42 +-151,875, M54 +-125,708, M42 +-131,593 pulses per half turn.
* The table has no PWM, Drive Mode, Profile Velocity, Bus Watchdog, Moving Status, trajectory or
  Realtime Tick items, and of the gains only Velocity I/P (586/588) and Position P (594).

Other facts checked against the e-Manual:

* X: 0.229 rev/min, 214.577 rev/min^2, PWM 885 = 100 % (0.113 %/LSB), 2.69 mA (1.34 mA on
  XH430-V, 1 mA on XL330/XC330; XL430, XC430, 2XL430, 2XC430 report Present Load in 0.1 %
  instead of a current).
* P and PRO "-R(A)" share units: 0.01 rev/min, 1 rev/min^2, 1 mA, PWM 2009 = 100 %. Our shared
  notes list PWM as "none" for PRO; that holds only for the old "-R" firmware, PRO(A) has PWM.
* X Startup Configuration (60) exists from firmware v45 (X330: v46) although the SDK X files omit
  it; the X Acceleration Limit (40) appears only in early e-Manual revisions (the notes call it
  undocumented) and is not exposed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

NAN = math.nan

X_VELOCITY_RPM = 0.229
X_ACCELERATION_RPM2 = 214.577
X_PWM_FULL_SCALE = 885
P_VELOCITY_RPM = 0.01
P_ACCELERATION_RPM2 = 1.0
P_PWM_FULL_SCALE = 2009
OLD_PRO_MOTOR_ACCELERATION_RPM2 = 58000.0


@dataclass(frozen=True)
class ModelFacts:
    """What we know about one model number beyond the SDK file."""

    name: str
    series: str  # "X" | "P" | "PRO"
    sdk_file: Optional[str]  # None: old PRO, table below
    current_ma: float
    velocity_rpm: float
    acceleration_rpm2: float
    pwm_full_scale: float  # NaN where the model has no PWM items
    half_turn_pulses: int = 0  # P / PRO: pulses per half revolution; X: 0 (4096 per turn)
    extra_items: Dict[str, Tuple[int, int]] = field(default_factory=dict)
    old_pro: bool = False
    modes: Optional[Tuple[int, ...]] = None  # operating modes, when not those of the layout
    #: (lowest, highest) goal/present position in pulses where the model has a range of its own
    #: instead of a turn around its zero (the RH-P12-RN(A) stroke)
    position_range: Optional[Tuple[int, int]] = None
    #: the topics switch it only to its own operating modes, whatever its family offers
    own_modes: bool = False
    #: items of the table it is built on (the old PRO one) that this model lacks
    missing_items: Tuple[str, ...] = ()


def _x(name: str, sdk_file: str, current_ma: float, extra: Optional[Dict[str, Tuple[int, int]]] = None,
       modes: Optional[Tuple[int, ...]] = None) -> ModelFacts:
    return ModelFacts(name, "X", sdk_file, current_ma, X_VELOCITY_RPM, X_ACCELERATION_RPM2,
                      X_PWM_FULL_SCALE, 0, dict(extra or {}), modes=modes, own_modes=modes is not None)


def _p(name: str, series: str, sdk_file: str, half_turn: int,
       extra: Optional[Dict[str, Tuple[int, int]]] = None) -> ModelFacts:
    return ModelFacts(name, series, sdk_file, 1.0, P_VELOCITY_RPM, P_ACCELERATION_RPM2,
                      P_PWM_FULL_SCALE, half_turn, dict(extra or {}))


def _old_pro(name: str, rpm: float, current_ma: float, half_turn: int,
             acceleration_rpm2: Optional[float] = None, modes: Optional[Tuple[int, ...]] = None) -> ModelFacts:
    accel = OLD_PRO_MOTOR_ACCELERATION_RPM2 * rpm if acceleration_rpm2 is None else acceleration_rpm2
    return ModelFacts(name, "PRO", None, current_ma, rpm, accel, NAN, half_turn, {}, old_pro=True, modes=modes)


# X items the SDK files leave out but the e-Manual lists: Startup Configuration (60, 1 byte) is
# documented for X430/X540 from firmware v45 and X330 from v46 (older firmware leaves it
# reserved). X330 PWM Slope (62) is already in the SDK files. The X "Acceleration Limit" (40) of
# early e-Manual versions is no longer documented, so X models do not expose it.
# Backup Ready (147) exists from firmware v45 (X330: v46) as well; the SDK X files omit it.
_X430_540_EXTRA: Dict[str, Tuple[int, int]] = {"startup_configuration": (60, 1), "backup_ready": (147, 1)}
_X330_EXTRA: Dict[str, Tuple[int, int]] = {"startup_configuration": (60, 1), "backup_ready": (147, 1)}
# XC335-T332: what its model file (dynamixel_hardware_interface param/dxl_model/xc335_t332.model) lists
# beyond the XC330 rows: Startup Configuration at 60 as 2 bytes, and no Backup Ready (147)
_XC335_EXTRA: Dict[str, Tuple[int, int]] = {"startup_configuration": (60, 2)}

_CURRENT_X = 2.69
_CURRENT_X330 = 1.0
_CURRENT_XH430_V = 1.34
_NO_CURRENT = NAN  # XL430, XC430, 2XL430, 2XC430: no current sensor (Present Load instead)

_CURRENT_MX = 3.36  # MX-64(2.0), MX-106(2.0): "about 3.36 [mA]" per LSB

# MX(2.0): MX-28 has velocity, position, extended position and PWM control only (no current
# sensor: Present Load at 126); MX-64 and MX-106 have all six modes of the X table. So have XL430-W250,
# XC430-W150/W240, 2XL430-W250 and 2XC430-W250 (e-Manual "Operating Mode": 1, 3, 4, 16; no current
# control and no current-based position control without a current sensor).
_NO_CURRENT_MODES = (1, 3, 4, 16)
_MX_28_MODES = _NO_CURRENT_MODES

# RH-P12-RN(A) (e-Manual platform/rh_p12_rn_a): the P table (model file rh_p12_rn.model) with the
# P units (1 mA, 0.01 rev/min, 1 rev/min^2, PWM 2009); Operating Mode 0 (current) or 5 (current-based
# position, the default) only; Goal/Present Position 1 pulse over 0 (open) .. 1,150 (its limits), and
# the page's "Degree of Precision 0.088 deg" (12-bit encoder over 360 deg) makes a pulse 360/4096 deg.
# The SDK file's type info (740 pulses = 1.099 rad, 0.0851 deg a pulse) and its velocity unit (0.114 rpm)
# disagree with the page; the page is followed.
_RH_P12_RN_A = ModelFacts("RH-P12-RN(A)", "P", "rh_p12_rn.model", 1.0, P_VELOCITY_RPM, P_ACCELERATION_RPM2,
                          P_PWM_FULL_SCALE, 2048, {"external_port_data_1": (600, 2), "external_port_data_2": (602, 2),
                                                   "external_port_data_3": (604, 2), "external_port_data_4": (606, 2)},
                          modes=(0, 5), position_range=(0, 1150), own_modes=True)

# RH-P12-RN, the gripper's older firmware (e-Manual platform/rh_p12_rn): model number 35073, the old
# PRO "-R" table without Homing Offset and the velocity gains, with Position D / I Gain at 590 / 592;
# Present Current "about 4.02 mA", velocity 0.114 rpm, Goal Acceleration 214.577 rev/min^2, no PWM;
# position 0 (open) .. 1,150 pulses of 0.088 deg; modes 0 and 5 only. Not in the SDK's files.
_RH_P12_RN = ModelFacts("RH-P12-RN", "PRO", None, 4.02, 0.114, 214.577, NAN, 2048,
                        {"position_d_gain": (590, 2), "position_i_gain": (592, 2)}, old_pro=True, modes=(0, 5),
                        position_range=(0, 1150), own_modes=True,
                        missing_items=("homing_offset", "velocity_i_gain", "velocity_p_gain"))

_PRO_54 = 33000.0 / 2048.0
_PRO_42 = 8250.0 / 2048.0

MODEL_FACTS: Dict[int, ModelFacts] = {
    # ---- MX (2.0) firmware: the X table (SDK files mx_*.model; e-Manual dxl/mx/mx-*-2) ----------
    30: _x("MX-28(2.0)", "mx_28.model", _NO_CURRENT, modes=_MX_28_MODES),
    311: _x("MX-64(2.0)", "mx_64.model", _CURRENT_MX),
    321: _x("MX-106(2.0)", "mx_106.model", _CURRENT_MX),
    # ---- X series ------------------------------------------------------------------------------
    1000: _x("XH430-W350", "xh430_w350.model", _CURRENT_X, _X430_540_EXTRA),
    1001: _x("XD430-T350", "xd430_t350.model", _CURRENT_X, _X430_540_EXTRA),
    1010: _x("XH430-W210", "xh430_w210.model", _CURRENT_X, _X430_540_EXTRA),
    1011: _x("XD430-T210", "xd430_t210.model", _CURRENT_X, _X430_540_EXTRA),
    1020: _x("XM430-W350", "xm430_w350.model", _CURRENT_X, _X430_540_EXTRA),
    1030: _x("XM430-W210", "xm430_w210.model", _CURRENT_X, _X430_540_EXTRA),
    1040: _x("XH430-V350", "xh430_v350.model", _CURRENT_XH430_V, _X430_540_EXTRA),
    1050: _x("XH430-V210", "xh430_v210.model", _CURRENT_XH430_V, _X430_540_EXTRA),
    1060: _x("XL430-W250", "xl430_w250.model", _NO_CURRENT, _X430_540_EXTRA, modes=_NO_CURRENT_MODES),
    1070: _x("XC430-W150", "xc430_w150.model", _NO_CURRENT, _X430_540_EXTRA, modes=_NO_CURRENT_MODES),
    1080: _x("XC430-W240", "xc430_w240.model", _NO_CURRENT, _X430_540_EXTRA, modes=_NO_CURRENT_MODES),
    1090: _x("2XL430-W250", "2xl430_w250.model", _NO_CURRENT, _X430_540_EXTRA, modes=_NO_CURRENT_MODES),
    1100: _x("XH540-W270", "xh540_w270.model", _CURRENT_X, _X430_540_EXTRA),
    1101: _x("XD540-T270", "xd540_t270.model", _CURRENT_X, _X430_540_EXTRA),
    1110: _x("XH540-W150", "xh540_w150.model", _CURRENT_X, _X430_540_EXTRA),
    1111: _x("XD540-T150", "xd540_t150.model", _CURRENT_X, _X430_540_EXTRA),
    1120: _x("XM540-W270", "xm540_w270.model", _CURRENT_X, _X430_540_EXTRA),
    1130: _x("XM540-W150", "xm540_w150.model", _CURRENT_X, _X430_540_EXTRA),
    1140: _x("XH540-V270", "xh540_v270.model", _CURRENT_X, _X430_540_EXTRA),
    1150: _x("XH540-V150", "xh540_v150.model", _CURRENT_X, _X430_540_EXTRA),
    1160: _x("2XC430-W250", "2xc430_w250.model", _NO_CURRENT, _X430_540_EXTRA, modes=_NO_CURRENT_MODES),
    1170: _x("XW540-T260", "xw540_t260.model", _CURRENT_X, _X430_540_EXTRA),
    1180: _x("XW540-T140", "xw540_t140.model", _CURRENT_X, _X430_540_EXTRA),
    1190: _x("XL330-M077", "xl330_m077.model", _CURRENT_X330, _X330_EXTRA),
    1200: _x("XL330-M288", "xl330_m288.model", _CURRENT_X330, _X330_EXTRA),
    1210: _x("XC330-T181", "xc330_t181.model", _CURRENT_X330, _X330_EXTRA),
    1220: _x("XC330-T288", "xc330_t288.model", _CURRENT_X330, _X330_EXTRA),
    1230: _x("XC330-M181", "xc330_m181.model", _CURRENT_X330, _X330_EXTRA),
    1240: _x("XC330-M288", "xc330_m288.model", _CURRENT_X330, _X330_EXTRA),
    # XM335-T323 (e-Manual page xm335-t323): the X330 items plus Backup Ready, 1 mA, 0.229 rpm;
    # its table equals the XC330 one (no SDK file of its own), 28 indirect entries at 168/224.
    1710: _x("XM335-T323", "xc330_t288.model", _CURRENT_X330, _X330_EXTRA),
    # XC335-T332: no e-Manual page; its model file (dynamixel_hardware_interface param/dxl_model/
    # xc335_t332.model) has the XC330 rows, Startup Configuration at 60 (2 bytes), no Backup Ready,
    # and 28 indirect entries at 168 / 224 as XM335; current in 1 mA as every 330/335 servo.
    1700: _x("XC335-T332", "xc330_t288.model", _CURRENT_X330, _XC335_EXTRA),
    1270: _x("XW430-T333", "xw430_t333.model", _CURRENT_X, _X430_540_EXTRA),
    # XW430-T200 has a table file but is missing from the SDK's number index.
    1280: _x("XW430-T200", "xw430_t200.model", _CURRENT_X, _X430_540_EXTRA),
    1310: _x("XW540-H260", "xw540_h260.model", _CURRENT_X, _X430_540_EXTRA),
    # ---- P series (pulses per half turn from the e-Manual / SDK type info) ---------------------
    2000: _p("PH42-020-S300-R", "P", "ph42_020_s300.model", 303750),
    2010: _p("PH54-100-S500-R", "P", "ph54_100_s500.model", 501923),
    2020: _p("PH54-200-S500-R", "P", "ph54_200_s500.model", 501923),
    2100: _p("PM42-010-S260-R", "P", "pm42_010_s260.model", 263187),
    2110: _p("PM54-040-S250-R", "P", "pm54_040_s250.model", 251417),
    2120: _p("PM54-060-S250-R", "P", "pm54_060_s250.model", 251417),
    # ---- PRO with advanced firmware "-R(A)": the P table and units, so the P series -------------
    43289: _p("M42-10-S260-R(A)", "P", "m42_10_s260_ra.model", 263187),
    46097: _p("M54-40-S250-R(A)", "P", "m54_40_s250_ra.model", 251417),
    46353: _p("M54-60-S250-R(A)", "P", "m54_60_s250_ra.model", 251417),
    51201: _p("H42-20-S300-R(A)", "P", "h42_20_s300_ra.model", 303750),
    53769: _p("H54-100-S500-R(A)", "P", "h54_100_s500_ra.model", 501923),
    54025: _p("H54-200-S500-R(A)", "P", "h54_200_s500_ra.model", 501923),
    # ---- RH-P12-RN(A) gripper: the P table, its own stroke and modes -----------------------------
    35074: _RH_P12_RN_A,
    # ---- old PRO "-R" firmware: our own table (OLD_PRO_ITEMS) ------------------------------------
    43288: _old_pro("M42-10-S260-R", 0.00389076, _PRO_42, 131593),
    46096: _old_pro("M54-40-S250-R", 0.00397746, _PRO_54, 125708),
    46352: _old_pro("M54-60-S250-R", 0.00397746, _PRO_54, 125708),
    51200: _old_pro("H42-20-S300-R", 0.00329218, _PRO_42, 151875),
    53768: _old_pro("H54-100-S500-R", 0.00199234, _PRO_54, 250961),
    54024: _old_pro("H54-200-S500-R", 0.00199234, _PRO_54, 250961),
    # L series ("-R" firmware, same table). e-Manual: Goal Velocity scale factor L54-50-S290
    # 0.00346667, L54-*-S500 0.00199234, L54-30-S400 0.00249657 rpm; resolution 207,692 /
    # 361,384 / 288,395 pulses per turn. L42-10-S300-R: 4096 pulses per turn, 0.114 rpm per LSB,
    # Goal Acceleration "214 RPM^2 @ Core Motor" (gear 303.75), velocity and position modes only.
    35073: _RH_P12_RN,
    35072: _old_pro("L42-10-S300-R", 0.114, _PRO_42, 2048, acceleration_rpm2=214.0 / 303.75, modes=(1, 3)),
    37896: _old_pro("L54-30-S500-R", 0.00199234, _PRO_54, 180692),
    37928: _old_pro("L54-30-S400-R", 0.00249657, _PRO_54, 144197),
    38152: _old_pro("L54-50-S500-R", 0.00199234, _PRO_54, 180692),
    38176: _old_pro("L54-50-S290-R", 0.00346667, _PRO_54, 103846),
}

# Old PRO "-R" control table (e-Manual, identical across the six models): name -> (address, size).
# Canonical names: Goal Torque is goal_current, Torque Limit is current_limit, Goal Acceleration
# is profile_acceleration.
OLD_PRO_ITEMS: Dict[str, Tuple[int, int]] = {
    "model_number": (0, 2),
    "model_information": (2, 4),
    "firmware_version": (6, 1),
    "id": (7, 1),
    "baud_rate": (8, 1),
    "return_delay_time": (9, 1),
    "operating_mode": (11, 1),
    "homing_offset": (13, 4),
    "moving_threshold": (17, 4),
    "temperature_limit": (21, 1),
    "max_voltage_limit": (22, 2),
    "min_voltage_limit": (24, 2),
    "acceleration_limit": (26, 4),
    "current_limit": (30, 2),
    "velocity_limit": (32, 4),
    "max_position_limit": (36, 4),
    "min_position_limit": (40, 4),
    "external_port_mode_1": (44, 1),
    "external_port_mode_2": (45, 1),
    "external_port_mode_3": (46, 1),
    "external_port_mode_4": (47, 1),
    "shutdown": (48, 1),
    "torque_enable": (562, 1),
    "led_red": (563, 1),
    "led_green": (564, 1),
    "led_blue": (565, 1),
    "velocity_i_gain": (586, 2),
    "velocity_p_gain": (588, 2),
    "position_p_gain": (594, 2),
    "goal_position": (596, 4),
    "goal_velocity": (600, 4),
    "goal_current": (604, 2),
    "profile_acceleration": (606, 4),
    "moving": (610, 1),
    "present_position": (611, 4),
    "present_velocity": (615, 4),
    "present_current": (621, 2),
    "present_input_voltage": (623, 2),
    "present_temperature": (625, 1),
    "external_port_data_1": (626, 2),
    "external_port_data_2": (628, 2),
    "external_port_data_3": (630, 2),
    "external_port_data_4": (632, 2),
    "registered_instruction": (890, 1),
    "status_return_level": (891, 1),
    "hardware_error_status": (892, 1),
}

# Items whose value is a two's-complement number. Position limits are signed because P / PRO
# limits are negative (X limits 0..4095 read the same either way). Bus Watchdog reads -1 once it
# has tripped (e-Manual: "Bus Watchdog Error"), 1..127 while armed.
SIGNED_ITEMS = frozenset({
    "homing_offset", "goal_pwm", "goal_current", "goal_velocity", "goal_position",
    "present_pwm", "present_current", "present_load", "present_velocity", "present_position",
    "velocity_trajectory", "position_trajectory", "max_position_limit", "min_position_limit",
    "bus_watchdog",
})

# First RAM address per table layout: everything below is EEPROM (writable only with torque off).
EEPROM_END = {"X": 64, "X330": 64, "P": 512, "OLD_PRO": 562}

# Baud Rate register value -> bps per layout (e-Manual "Baud Rate(8)"): 0..6 are shared; X430/540
# add 7 = 4.5M; X330 (and XM335) stop at 4M; P and PRO "-RA" have 8 = 6M and 9 = 10.5M; the old
# PRO "-R" firmware has 8 = 10.5M.
_BAUD_COMMON = {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000, 6: 4_000_000}
BAUD_RATES = {
    "X": {**_BAUD_COMMON, 7: 4_500_000},
    "X330": dict(_BAUD_COMMON),
    "P": {**_BAUD_COMMON, 7: 4_500_000, 8: 6_000_000, 9: 10_500_000},
    "OLD_PRO": {**_BAUD_COMMON, 7: 4_500_000, 8: 10_500_000},
}

# Operating modes per layout (old PRO "-R": no PWM, no current-based position).
OPERATING_MODES_OF = {"X": (0, 1, 3, 4, 5, 16), "X330": (0, 1, 3, 4, 5, 16), "P": (0, 1, 3, 4, 5, 16),
                      "OLD_PRO": (0, 1, 3, 4)}

# Indirect blocks per layout as (first Indirect Address, first Indirect Data, entries), and the
# addresses an Indirect Address may hold (e-Manual control tables):
# X430/540: 1-28 at 168/224 and 29-56 at 578/634, targets 64..661. X330: 1-20 at 168, data at 208
# from firmware v52 (224 before), targets 64..227. XM335: 1-28 at 168/224, targets 64..251.
# P and PRO "-RA": 1-128 at 168/634 (the addresses in EEPROM), targets 512..1023. Old PRO "-R":
# 1-256 at 49/634, targets 562..949.
INDIRECT = {
    "X": (((168, 224, 28), (578, 634, 28)), (64, 661)),
    "X330": (((168, 208, 20),), (64, 227)),
    "XM335": (((168, 224, 28),), (64, 251)),
    "P": (((168, 634, 128),), (512, 1023)),
    "OLD_PRO": (((49, 634, 256),), (562, 949)),
}
X330_INDIRECT_DATA_BEFORE_FW52 = 224

# Bytes of control table per layout (the last address + 1).
TABLE_SIZE = {"X": 662, "X330": 228, "XM335": 252, "P": 1024, "OLD_PRO": 1024}
