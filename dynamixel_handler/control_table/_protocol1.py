"""Protocol 1.0 servos: the AX, RX, DX, EX and MX (Protocol 1.0 firmware) models, as data.

Facts from each model's ROBOTIS e-Manual page (emanual.robotis.com, ``docs/en/dxl/ax/ax-12a``,
``ax-12w``, ``ax-18a``; ``rx/rx-10``, ``rx-24f``, ``rx-28``, ``rx-64``; ``dx/dx-113``, ``dx-116``,
``dx-117``; ``ex/ex-106+``; ``mx/mx-12w``, ``mx-28``, ``mx-64``, ``mx-106``), the sections they
include (``_includes/en/dxl/control_table_mx_goal_position``, ``_mx_angle_limit``,
``_multiturn_offset``, ``_resolution_divider``, ``_goal_acceleration``,
``_magnet_present_position``, ``_volt_limit``) and the Protocol 1.0 page (``dxl/protocol1``):

* One table for all: Model Number 0 (2 bytes), Firmware 2, ID 3, Baud Rate 4, Return Delay Time 5
  (2 µs), CW / CCW Angle Limit 6 / 8, Temperature Limit 11, Min / Max Voltage Limit 12 / 13
  (0.1 V), Max Torque 14, Status Return Level 16, Alarm LED 17, Shutdown 18; RAM from 24: Torque
  Enable 24, LED 25, Goal Position 30, Moving Speed 32, Torque Limit 34, Present Position 36,
  Present Speed 38, Present Load 40, Present Voltage 42, Present Temperature 43, Registered 44,
  Moving 46, Lock 47, Punch 48. AX, RX, DX and EX have CW / CCW Compliance Margin and Slope at
  26-29, MX D / I / P Gain at 26 / 27 / 28, Multi Turn Offset 20, Resolution Divider 22, Realtime
  Tick 50 and Goal Acceleration 73 (about 8.583 deg/s² a unit). EX-106+ and MX-106 have Drive Mode
  (10, dual mode); EX-106+ has Sensed Current (56: 10 mA a unit, 512 = 0 mA); MX-64 and MX-106 have
  Current (68: 4.5 mA a unit, 2048 = 0 mA), Torque Control Mode Enable (70) and Goal Torque (71:
  4.5 mA a unit, bit 10 the direction).
* Positions: AX, RX and DX 0..1023 over 300 deg (512 the middle); MX 0..4095 over a turn (0.088 deg,
  2048 the middle); EX-106+ 0..4095 over 250.92 deg (0.06 deg, 2048 the middle). MX multi-turn
  (both Angle Limits 4095): -28,672..28,672, two's complement; Multi Turn Offset -24,576..24,576.
* MX-12W: its page includes the MX multi-turn sections (Multi Turn Offset, both limits 4095), so it
  has multi-turn like the MX-28/64/106.
* Speeds: Moving Speed 0..1023 at about 0.111 rpm (AX, RX, DX, EX), 0.114 rpm (MX-28/64/106) or
  0.916 rpm (MX-12W); in Joint Mode 0 means "as fast as the motor goes", in Wheel Mode (both Angle
  Limits 0) bit 10 is the direction (set: CW). Present Speed and Present Load (about 0.1 %) carry the
  direction in bit 10 too. DX-113/116/117 have no Wheel Mode.
* Baud Rate value v runs at 2,000,000 / (v + 1) bps; the tables name 1 (1 Mbps), 3, 4, 7, 9, 16
  (115,200, -2.1 %), 34 (57,600, +0.8 %), 103 and 207 (9,600); MX adds 250 = 2.25 M, 251 = 2.5 M,
  252 = 3 M. Factory: 1 on AX and MX-12W, 34 on the rest.
* Status error bits (and Alarm LED / Shutdown bits): 0 input voltage, 1 angle limit, 2 overheating,
  3 range, 4 checksum, 5 overload, 6 instruction.

Where the pages disagree with themselves or with the servos, and what is kept:

* MX-12W: its table gives Model Number 104; the servo reports 360 (0x0168, whose low byte is 104),
  which the set-up tool and other drivers read: 360 is kept.
* EX-106+: its Goal / Present Position sections are the AX text (0..1023, 0.29 deg); its table
  (CCW Angle Limit 4,095), its specifications (0.06 deg, 0..251 deg) and wheel-mode text (0.06 deg)
  give 0..4095 over 250.92 deg: kept.
* The MX Goal Position section calls the angle limit error bit 0x01 (it is bit 1, 0x02); the
  Resolution Divider section calls multi-turn "both CW and CCW are 0" (that is Wheel Mode; the
  Angle Limit section says 4095).
* MX-64: Max Voltage Limit initial 240, outside the 50..160 its section gives (kept as the initial
  value; the range is the section's). The MX Current item is marked RW and initial 0 in the tables,
  its section says it reads 2,048 with no current: read here as a measurement.
* RX and DX specifications say "7343 bps ~ 1 Mbps"; the slowest rate, value 254, is 7,843 bps.
* Temperature Limit: the section most pages include gives 0..100 (kept); the AX-12W page 0..99.
* The AX-12W and AX-18A pages say EEPROM is written only with "Torque Enable(64)" off: an X-series
  sentence (64 is not an AX address); Protocol 1.0 servos take EEPROM writes with torque on.
* AX-12, AX-12+ and AX-12A share model number 12 (one model here, named AX-12A).
"""
from __future__ import annotations

from typing import Dict, FrozenSet, Mapping, Optional, Tuple

#: (name, address, size, eeprom, read_only, direction_bit, signed)
Row = Tuple[str, int, int, bool, bool, int, bool]
DIRECTION_BIT = 10
EEPROM_END = 24

_COMMON: Tuple[Row, ...] = (
    ("model_number", 0, 2, True, True, 0, False), ("firmware_version", 2, 1, True, True, 0, False),
    ("id", 3, 1, True, False, 0, False), ("baud_rate", 4, 1, True, False, 0, False),
    ("return_delay_time", 5, 1, True, False, 0, False),
    ("min_position_limit", 6, 2, True, False, 0, False),   # CW Angle Limit
    ("max_position_limit", 8, 2, True, False, 0, False),   # CCW Angle Limit
    ("temperature_limit", 11, 1, True, False, 0, False), ("min_voltage_limit", 12, 1, True, False, 0, False),
    ("max_voltage_limit", 13, 1, True, False, 0, False),
    ("pwm_limit", 14, 2, True, False, 0, False),           # Max Torque: the output's limit, 0.1 % a unit
    ("status_return_level", 16, 1, True, False, 0, False), ("alarm_led", 17, 1, True, False, 0, False),
    ("shutdown", 18, 1, True, False, 0, False),
    ("torque_enable", 24, 1, False, False, 0, False), ("led", 25, 1, False, False, 0, False),
    ("goal_velocity", 32, 2, False, False, DIRECTION_BIT, False),     # Moving Speed
    ("torque_limit", 34, 2, False, False, 0, False),
    ("present_velocity", 38, 2, False, True, DIRECTION_BIT, False),   # Present Speed
    ("present_load", 40, 2, False, True, DIRECTION_BIT, False),
    ("present_input_voltage", 42, 1, False, True, 0, False), ("present_temperature", 43, 1, False, True, 0, False),
    ("registered_instruction", 44, 1, False, True, 0, False), ("moving", 46, 1, False, True, 0, False),
    ("lock", 47, 1, False, False, 0, False), ("punch", 48, 2, False, False, 0, False),
)
_COMPLIANCE: Tuple[Row, ...] = (
    ("cw_compliance_margin", 26, 1, False, False, 0, False), ("ccw_compliance_margin", 27, 1, False, False, 0, False),
    ("cw_compliance_slope", 28, 1, False, False, 0, False), ("ccw_compliance_slope", 29, 1, False, False, 0, False),
)
_POSITIONS_10BIT: Tuple[Row, ...] = (
    ("goal_position", 30, 2, False, False, 0, False), ("present_position", 36, 2, False, True, 0, False),
)
_MX: Tuple[Row, ...] = (
    ("multi_turn_offset", 20, 2, True, False, 0, True), ("resolution_divider", 22, 1, True, False, 0, False),
    ("position_d_gain", 26, 1, False, False, 0, False), ("position_i_gain", 27, 1, False, False, 0, False),
    ("position_p_gain", 28, 1, False, False, 0, False),
    ("goal_position", 30, 2, False, False, 0, True), ("present_position", 36, 2, False, True, 0, True),
    ("realtime_tick", 50, 2, False, True, 0, False),
    ("profile_acceleration", 73, 1, False, False, 0, False),          # Goal Acceleration
)
_MX_CURRENT: Tuple[Row, ...] = (
    ("present_current", 68, 2, False, True, 0, False),                # Current: 2048 = 0 mA
    ("torque_control_mode_enable", 70, 1, False, False, 0, False),
    ("goal_current", 71, 2, False, False, DIRECTION_BIT, False),      # Goal Torque
)
_DRIVE_MODE: Tuple[Row, ...] = (("drive_mode", 10, 1, True, False, 0, False),)
_EX_CURRENT: Tuple[Row, ...] = (("present_current", 56, 2, False, True, 0, False),)  # Sensed Current: 512 = 0

AX_RX_DX = _COMMON + _COMPLIANCE + _POSITIONS_10BIT
EX = _COMMON + _COMPLIANCE + _POSITIONS_10BIT + _DRIVE_MODE + _EX_CURRENT
MX = _COMMON + _MX
MX_CURRENT = MX + _MX_CURRENT

# Baud Rate: value v -> 2,000,000 / (v + 1) bps, the tables' nominal rates where they name one
_NOMINAL = {16: 115_200, 34: 57_600, 103: 19_200, 207: 9_600}


def _bauds(values: range, extra: Mapping[int, int] = {}) -> Dict[int, int]:
    rates = {v: _NOMINAL.get(v, round(2_000_000 / (v + 1))) for v in values}
    rates.update(extra)
    return rates


#: AX, RX, DX, EX: 7,843 bps (254) .. 1 Mbps (1)
BAUDS_1: Mapping[int, int] = _bauds(range(1, 255))
#: MX: 8,000 bps (249) .. 2 Mbps (0), then 2.25, 2.5 and 3 Mbps
BAUDS_MX: Mapping[int, int] = _bauds(range(0, 250), {250: 2_250_000, 251: 2_500_000, 252: 3_000_000})


def actual_bps(value: int) -> float:
    """The line speed a Baud Rate value really runs at (the clock divider's, before the tables'
    rounding to a nominal rate)."""
    return {250: 2_250_000.0, 251: 2_500_000.0, 252: 3_000_000.0}.get(value, 2_000_000 / (value + 1))


#: mode name -> the code the handler's modes use; a Protocol 1.0 servo has no Operating Mode
#: register: the Angle Limits (and Torque Control Mode Enable) select it (``mode_of``)
MODE_CODES: Mapping[str, int] = {"current": 0, "velocity": 1, "position": 3, "ex_position": 4}
MULTI_TURN_LIMIT = 4095
MULTI_TURN_GOAL = 28_672


def mode_of(cw_limit: int, ccw_limit: int, torque_control: int = 0) -> str:
    """The mode the registers select: Torque Control Mode Enable 1 is current control; both Angle
    Limits 0 Wheel Mode (velocity); both 4095 on MX multi-turn (ex_position); else Joint Mode."""
    if torque_control:
        return "current"
    if cw_limit == 0 and ccw_limit == 0:
        return "velocity"
    if cw_limit == MULTI_TURN_LIMIT and ccw_limit == MULTI_TURN_LIMIT:
        return "ex_position"
    return "position"


class Spec:
    """One model's facts beyond its rows: position scale and range, speed unit, modes, baud table."""

    def __init__(self, name: str, family: str, rows: Tuple[Row, ...], factory: Mapping[str, int],
                 span_deg: float = 300.0, top: int = 1023, rpm: float = 0.111,
                 modes: Tuple[str, ...] = ("position", "velocity"), current_ma: Optional[float] = None,
                 current_zero: int = 0, bauds: Mapping[int, int] = BAUDS_1) -> None:
        self.name, self.family, self.rows, self.factory = name, family, rows, factory
        self.top = top
        #: MX: 4096 steps over a turn; AX/RX/DX: 1023 steps over 300 deg; EX: 4095 over 250.92 deg
        self.deg_per_pulse = 360.0 / 4096.0 if span_deg == 360.0 else span_deg / top
        self.zero = (top + 1) // 2
        self.rpm, self.modes, self.bauds = rpm, modes, bauds
        self.current_ma, self.current_zero = current_ma, current_zero

    @property
    def eeprom(self) -> FrozenSet[str]:
        return frozenset(r[0] for r in self.rows if r[3])


def _ax(temperature: int = 70, torque: int = 1023, margin: int = 1, slope: int = 32) -> Dict[str, int]:
    """An AX page's initial values (what AX-12W and AX-18A change)."""
    return {"id": 1, "baud_rate": 1, "return_delay_time": 250, "min_position_limit": 0, "max_position_limit": 1023,
            "temperature_limit": temperature, "min_voltage_limit": 60, "max_voltage_limit": 140, "pwm_limit": torque,
            "status_return_level": 2, "alarm_led": 36, "shutdown": 36, "torque_enable": 0, "led": 0,
            "cw_compliance_margin": margin, "ccw_compliance_margin": margin, "cw_compliance_slope": slope,
            "ccw_compliance_slope": slope, "registered_instruction": 0, "moving": 0, "lock": 0, "punch": 32}


def _rx(temperature: int = 80, margin: int = 1) -> Dict[str, int]:
    """An RX / DX page's initial values: 57,600 bps, 19.0 V, the temperature and margins per model."""
    return {**_ax(temperature, 1023, margin), "baud_rate": 34, "max_voltage_limit": 190}


def _mx(max_v: int = 160, d: int = 0, p: int = 32, punch: int = 0, baud: int = 34,
        ccw: int = 4095) -> Dict[str, int]:
    """An MX (or, with its items, EX) page's initial values."""
    return {"id": 1, "baud_rate": baud, "return_delay_time": 250, "min_position_limit": 0,
            "max_position_limit": ccw, "temperature_limit": 80, "min_voltage_limit": 60,
            "max_voltage_limit": max_v, "pwm_limit": 1023, "status_return_level": 2, "alarm_led": 36,
            "shutdown": 36, "multi_turn_offset": 0, "resolution_divider": 1, "torque_enable": 0, "led": 0,
            "position_d_gain": d, "position_i_gain": 0, "position_p_gain": p, "registered_instruction": 0,
            "moving": 0, "lock": 0, "punch": punch, "profile_acceleration": 0, "drive_mode": 0,
            "torque_control_mode_enable": 0, "goal_current": 0,
            "cw_compliance_margin": 1, "ccw_compliance_margin": 1, "cw_compliance_slope": 32,
            "ccw_compliance_slope": 32}


_MX_MODES = ("position", "velocity", "ex_position")
_EX = {**_mx(max_v=240), "punch": 0}

#: model number -> its facts (e-Manual page named beside each)
SPECS: Mapping[int, Spec] = {
    12: Spec("AX-12A", "AX", AX_RX_DX, _ax()),                                          # ax/ax-12a
    300: Spec("AX-12W", "AX", AX_RX_DX, _ax(margin=4, slope=64)),                        # ax/ax-12w
    18: Spec("AX-18A", "AX", AX_RX_DX, _ax(temperature=75, torque=983)),                 # ax/ax-18a
    10: Spec("RX-10", "RX", AX_RX_DX, _rx()),                                            # rx/rx-10
    24: Spec("RX-24F", "RX", AX_RX_DX, _rx()),                                           # rx/rx-24f
    28: Spec("RX-28", "RX", AX_RX_DX, _rx()),                                            # rx/rx-28
    64: Spec("RX-64", "RX", AX_RX_DX, _rx()),                                            # rx/rx-64
    113: Spec("DX-113", "DX", AX_RX_DX, _rx(85, 0), modes=("position",)),                 # dx/dx-113
    116: Spec("DX-116", "DX", AX_RX_DX, _rx(85, 0), modes=("position",)),                 # dx/dx-116
    117: Spec("DX-117", "DX", AX_RX_DX, _rx(80, 1), modes=("position",)),                 # dx/dx-117
    107: Spec("EX-106+", "EX", EX, _EX, span_deg=250.92, top=4095,                       # ex/ex-106+
              current_ma=10.0, current_zero=512),
    360: Spec("MX-12W", "MX1", MX, _mx(d=8, p=8, punch=32, baud=1), 360.0, 4095, 0.916,  # mx/mx-12w
              _MX_MODES, bauds=BAUDS_MX),
    29: Spec("MX-28", "MX1", MX, _mx(), 360.0, 4095, 0.114, _MX_MODES, bauds=BAUDS_MX),   # mx/mx-28
    310: Spec("MX-64", "MX1", MX_CURRENT, _mx(max_v=240), 360.0, 4095, 0.114,            # mx/mx-64
              _MX_MODES + ("current",), 4.5, 2048, BAUDS_MX),
    320: Spec("MX-106", "MX1", MX_CURRENT + _DRIVE_MODE, _mx(), 360.0, 4095, 0.114,      # mx/mx-106
              _MX_MODES + ("current",), 4.5, 2048, BAUDS_MX),
}

#: Goal Acceleration: about 8.583 deg/s² a unit (254 = 2,180 deg/s²)
ACCELERATION_DEG_SS = 8.583
#: Max Torque / Torque Limit / Present Load: 1023 = 100 %
OUTPUT_FULL_SCALE = 1023
#: EEPROM item -> the RAM item the servo copies it into at power on (Torque Limit := Max Torque)
RAM_COPIES: Mapping[str, str] = {"pwm_limit": "torque_limit"}
#: status error byte, Alarm LED and Shutdown: cause -> bit
ERROR_BITS: Tuple[Tuple[str, int], ...] = (
    ("input_voltage", 0), ("angle_limit", 1), ("overheating", 2), ("range", 3), ("checksum", 4),
    ("overload", 5), ("instruction", 6))


def ranges(spec: Spec) -> Dict[str, Tuple[int, int]]:
    """The values the model's pages allow its items (raw), where narrower than the bytes."""
    top = spec.top
    mx = spec.family == "MX1"
    out = {
        "id": (0, 253), "return_delay_time": (0, 254), "status_return_level": (0, 2),
        "min_position_limit": (0, top), "max_position_limit": (0, top),
        "goal_position": (-MULTI_TURN_GOAL, MULTI_TURN_GOAL) if mx else (0, top),
        "pwm_limit": (0, 1023), "torque_limit": (0, 1023), "punch": (0, 1023),
        "min_voltage_limit": (50, 160 if mx else 250), "max_voltage_limit": (50, 160 if mx else 250),
        "temperature_limit": (0, 100), "torque_enable": (0, 1), "led": (0, 1), "lock": (0, 1), "alarm_led": (0, 127), "shutdown": (0, 127),
        "cw_compliance_slope": (0, 254), "ccw_compliance_slope": (0, 254),
        "position_d_gain": (0, 254), "position_i_gain": (0, 254), "position_p_gain": (0, 254),
        "multi_turn_offset": (-24_576, 24_576), "resolution_divider": (1, 4), "profile_acceleration": (0, 254),
        "torque_control_mode_enable": (0, 1),
    }
    names = {r[0] for r in spec.rows}
    return {name: span for name, span in out.items() if name in names}


#: the items that select a Protocol 1.0 servo's mode
LIMIT_ITEMS = ("min_position_limit", "max_position_limit")
TORQUE_CONTROL_ITEM = "torque_control_mode_enable"


class LimitModes:
    """How a Protocol 1.0 servo's mode is read and set: it has no Operating Mode register; the
    Angle Limits (CW, CCW) select Joint Mode (position), Wheel Mode (both 0: velocity) and, on MX,
    multi-turn (both 4095: ex_position); Torque Control Mode Enable (MX-64/106) selects current
    control over any of them. Back to Joint Mode, the limits it had are written again (``joint``),
    or the factory ones (0, ``top``) when none are known."""

    def __init__(self, top: int, torque_control: bool) -> None:
        self.top = top
        self.torque_control = torque_control
        #: what is read to know the mode
        self.items: Tuple[str, ...] = LIMIT_ITEMS + ((TORQUE_CONTROL_ITEM,) if torque_control else ())

    def code(self, values: Mapping[str, Optional[int]]) -> Optional[int]:
        """The mode's code (``MODE_CODES``) from the values of ``items`` (None: one is unknown)."""
        lo, hi = values.get(LIMIT_ITEMS[0]), values.get(LIMIT_ITEMS[1])
        torque = values.get(TORQUE_CONTROL_ITEM, 0) if self.torque_control else 0
        if lo is None or hi is None or torque is None:
            return None
        return MODE_CODES[mode_of(lo, hi, torque)]

    def writes(self, mode: str, joint: Optional[Tuple[int, int]] = None) -> Dict[str, int]:
        """The items to write, in order, to switch to ``mode``; ``joint``: Joint Mode's limits."""
        limits = {"velocity": (0, 0), "ex_position": (MULTI_TURN_LIMIT, MULTI_TURN_LIMIT)}.get(mode)
        out: Dict[str, int] = {}
        if self.torque_control:
            out[TORQUE_CONTROL_ITEM] = 1 if mode == "current" else 0
        if mode != "current":
            lo, hi = limits or joint or (0, self.top)
            out.update({LIMIT_ITEMS[0]: lo, LIMIT_ITEMS[1]: hi})
        return out
