"""Factory (initial) register values per model, from the "Initial Value" column of each model's
ROBOTIS e-Manual control table (ROBOTIS-GIT/emanual ``docs/en/dxl/{x,p,pro}/<model>.md``).

Only what differs between models or families is listed: limits, gains, thresholds, the shutdown
mask, PWM slope, the default baud rate where it is not 57600 bps, the External Port modes. The
values every Protocol 2.0 servo shares (ID 1, Return Delay Time 250, position mode, Status Return
Level 2, ...) are the simulator's business (``dynamixel_handler/sim/defaults.py``).

Where the manual leaves a value out, so does this table:

* old PRO "-R" firmware (H/M/L series): the pages give the Moving Threshold (50), Temperature
  Limit (80), voltage limits (40.0 / 15.0 V), Shutdown (58; 48 on the L42-10-S300-R) and External
  Port Mode (0), but no Acceleration, Torque or Velocity Limit, position limits or gains;
* PRO "-R(A)" firmware: the EEPROM area is given, the gains are not.

Notes on the pages themselves: the XD430/XD540 pages say their control tables are identical to
the XH430/XH540 of the same gear, and carry the same values; the XW430-T333 and XW430-T200 pages
list Protocol Type 1 as initial value, which the table below does not follow (the servos are
sold for Protocol 2.0, as every other X page says).
"""

from __future__ import annotations

from typing import Dict, Tuple

Values = Dict[str, int]

# (velocity I, velocity P, position D, position I, position P) gains
_GAINS = ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain", "position_p_gain")
_X_PORTS = {f"external_port_mode_{n}": 3 for n in (1, 2, 3, 4)}  # digital input, pull-down


def _gains(values: Tuple[int, int, int, int, int]) -> Values:
    return dict(zip(_GAINS, values))


def _x(velocity: int, current: int, gains: Tuple[int, int, int, int, int], *, temperature: int = 80,
       volts: Tuple[int, int] = (160, 95), shutdown: int = 52, **extra: int) -> Values:
    """An X model: its velocity limit, current limit (0 where it has none), gains and the rest."""
    values = {
        "moving_threshold": 10, "temperature_limit": temperature, "max_voltage_limit": volts[0],
        "min_voltage_limit": volts[1], "pwm_limit": 885, "current_limit": current,
        "velocity_limit": velocity, "max_position_limit": 4095, "min_position_limit": 0,
        "shutdown": shutdown, **_X_PORTS, **_gains(gains),
    }
    values.update(extra)
    return values


def _p(velocity: int, current: int, acceleration: int, half_turn: int, *, shutdown: int = 58,
       moving_threshold: int = 20, gains: Tuple[int, int, int, int, int] | None = None) -> Values:
    """A P or PRO "-R(A)" model; ``half_turn``: the Max Position Limit (Min is its negative)."""
    values = {
        "moving_threshold": moving_threshold, "temperature_limit": 80, "max_voltage_limit": 350,
        "min_voltage_limit": 150, "pwm_limit": 2009, "current_limit": current,
        "acceleration_limit": acceleration, "velocity_limit": velocity,
        "max_position_limit": half_turn, "min_position_limit": -half_turn, "shutdown": shutdown,
        **_X_PORTS,
    }
    if gains is not None:
        values.update(_gains(gains))
    return values


def _old_pro(shutdown: int = 58) -> Values:
    """The old PRO "-R" page (shared table): what it gives at all."""
    values = {"moving_threshold": 50, "temperature_limit": 80, "max_voltage_limit": 400,
              "min_voltage_limit": 150, "shutdown": shutdown}
    values.update({f"external_port_mode_{n}": 0 for n in (1, 2, 3, 4)})
    return values


_X430 = (1920, 100, 0, 0, 800)
_XH430_W = (1920, 100, 0, 0, 900)
_24V = (300, 110)
_X330_5V = (70, 35)
_X330_12V = (140, 55)

_MX_GAINS = (1920, 100, 0, 0, 850)

# Model number -> factory values; the comment names the e-Manual page (docs/en/dxl/...).
FACTORY: Dict[int, Values] = {
    # ---- MX (2.0): no current limit on the MX-28; an Acceleration Limit (40) of 32767 ----------
    30: _x(380, 0, _MX_GAINS, acceleration_limit=32767),            # mx/mx-28-2
    311: _x(435, 1941, _MX_GAINS, acceleration_limit=32767),        # mx/mx-64-2
    321: _x(360, 2047, _MX_GAINS, acceleration_limit=32767),        # mx/mx-106-2
    # ---- X430 ---------------------------------------------------------------------------------
    1000: _x(130, 648, _XH430_W),                                   # x/xh430-w350
    1001: _x(130, 648, _XH430_W),                                   # x/xd430-t350 (= XH430-W350)
    1010: _x(210, 648, _XH430_W),                                   # x/xh430-w210
    1011: _x(210, 648, _XH430_W),                                   # x/xd430-t210 (= XH430-W210)
    1020: _x(200, 1193, _X430),                                     # x/xm430-w350
    1030: _x(330, 1193, _X430),                                     # x/xm430-w210
    1040: _x(135, 689, _X430, volts=_24V),                          # x/xh430-v350
    1050: _x(380, 689, _X430, volts=_24V),                          # x/xh430-v210
    1060: _x(415, 0, (1000, 100, 4000, 0, 640), temperature=72, volts=(140, 60)),   # x/xl430-w250
    1070: _x(460, 0, (1920, 100, 0, 0, 460), volts=(160, 60)),      # x/xc430-w150
    1080: _x(306, 0, (1920, 100, 0, 0, 700), volts=(160, 60)),      # x/xc430-w240
    1090: _x(250, 0, (1800, 100, 2000, 0, 640), temperature=72, volts=(140, 60)),   # x/2xl430-w250
    1160: _x(275, 0, (1920, 100, 0, 0, 700), volts=(160, 60)),      # x/2xc430-w250
    1270: _x(139, 2047, _XH430_W),                                  # x/xw430-t333
    1280: _x(235, 2047, _XH430_W),                                  # x/xw430-t200
    # ---- X540 ---------------------------------------------------------------------------------
    1100: _x(167, 2047, _X430),                                     # x/xh540-w270
    1101: _x(167, 2047, _X430),                                     # x/xd540-t270 (= XH540-W270)
    1110: _x(300, 2047, _X430),                                     # x/xh540-w150
    1111: _x(300, 2047, _X430),                                     # x/xd540-t150 (= XH540-W150)
    1120: _x(128, 2047, _X430),                                     # x/xm540-w270
    1130: _x(380, 2047, _X430),                                     # x/xm540-w150
    1140: _x(128, 2047, _X430, volts=_24V),                         # x/xh540-v270
    1150: _x(230, 2047, _X430, volts=_24V),                         # x/xh540-v150
    1170: _x(167, 2047, _X430),                                     # x/xw540-t260
    1180: _x(304, 2047, _X430),                                     # x/xw540-t140
    1310: _x(145, 1188, _X430, volts=_24V),                         # x/xw540-h260
    # ---- X330, XM335 ----------------------------------------------------------------------------
    1190: _x(1620, 1750, (400, 40, 0, 400, 400), temperature=70, volts=_X330_5V, shutdown=53,
             pwm_slope=140),                                        # x/xl330-m077
    1200: _x(445, 1750, (1600, 180, 0, 0, 400), temperature=70, volts=_X330_5V, shutdown=53,
             pwm_slope=140),                                        # x/xl330-m288
    1210: _x(510, 910, (1200, 40, 0, 0, 900), temperature=70, volts=_X330_12V, pwm_slope=255),  # x/xc330-t181
    1220: _x(320, 910, (1200, 40, 0, 0, 900), temperature=70, volts=_X330_12V, pwm_slope=255),  # x/xc330-t288
    1230: _x(545, 2352, (1400, 100, 500, 0, 1200), temperature=70, volts=_X330_5V, pwm_slope=140),  # x/xc330-m181
    1240: _x(350, 2352, (1600, 50, 500, 0, 1100), temperature=70, volts=_X330_5V, pwm_slope=140),   # x/xc330-m288
    # x/xm335-t323: Velocity Limit 280 and gains 1800/50/0/0/2000 (the page's current table; an
    # older revision carried the XC330-T288 values 320 and 1200/40/0/0/900)
    1710: _x(280, 910, (1800, 50, 0, 0, 2000), temperature=70, volts=_X330_12V, pwm_slope=255,
             baud_rate=3, max_position_limit=3072, min_position_limit=1024),
    # XC335-T332 has no e-Manual page: the values of the XC330-T288 page, whose table it shares
    1700: _x(320, 910, (1200, 40, 0, 0, 900), temperature=70, volts=_X330_12V, pwm_slope=255),
    # ---- P ------------------------------------------------------------------------------------
    2000: _p(2920, 4500, 10765, 303454, gains=(502, 1332, 0, 0, 879)),          # p/ph42-020-s300-r
    2010: _p(2920, 15900, 4255632, 501433, gains=(1290, 3593, 0, 0, 502)),      # p/ph54-100-s500-r
    2020: _p(2900, 22740, 9982, 501433, shutdown=52, gains=(2209, 6153, 0, 0, 314)),  # p/ph54-200-s500-r
    2100: _p(2600, 1461, 4346756, 262931, gains=(6740, 2145, 0, 0, 1061)),      # p/pm42-010-s260-r
    2110: _p(2840, 4470, 11037, 251173, gains=(408, 1137, 0, 0, 502)),          # p/pm54-040-s250-r
    2120: _p(2830, 7980, 11145, 251173, gains=(813, 2265, 0, 0, 502)),          # p/pm54-060-s250-r
    # ---- PRO "-R(A)": gains not given ---------------------------------------------------------
    43289: _p(2600, 1461, 10867, 262931, shutdown=52),                          # pro/m42-10-s260-ra
    46097: _p(2840, 4470, 11037, 251173, shutdown=52),                          # pro/m54-40-s250-ra
    46353: _p(2830, 7980, 11145, 251173, shutdown=52, moving_threshold=50),     # pro/m54-60-s250-ra
    51201: _p(2920, 4500, 10765, 303454, shutdown=52),                          # pro/h42-20-s300-ra
    53769: _p(2920, 15900, 10639, 501433, shutdown=52, moving_threshold=50),    # pro/h54-100-s500-ra
    54025: _p(2900, 22740, 9982, 501433, shutdown=52),                          # pro/h54-200-s500-ra
    # ---- RH-P12-RN(A) (platform/rh_p12_rn_a): current-based position mode from the box; the
    # stroke 0 (open) .. 1150 pulses; gains "-" -------------------------------------------------
    35074: {**_p(2970, 1984, 3447, 1150, shutdown=52, moving_threshold=80), "min_position_limit": 0,
            "operating_mode": 5},
    # ---- old PRO "-R": the shared table of pro/h54-200-s500-r and its siblings -----------------
    **{number: _old_pro() for number in (43288, 46096, 46352, 51200, 53768, 54024, 37896, 37928, 38152, 38176)},
    35072: _old_pro(shutdown=48),                                   # pro/l42-10-s300-r
    # RH-P12-RN (platform/rh_p12_rn): the old PRO page's values and its limits; gains "-"
    35073: {**_old_pro(shutdown=48), "acceleration_limit": 255, "current_limit": 820, "velocity_limit": 100,
            "max_position_limit": 1150, "min_position_limit": 0, "moving_threshold": 10, "operating_mode": 5},
}
