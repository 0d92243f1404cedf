"""Health of each servo and of the bus as OK / WARN / ERROR, with the values behind it. ROS-free.

An operator reads these on ``/diagnostics`` (rqt_robot_monitor, diagnostic_aggregator): the level
says whether to act, the message says what is wrong in words, the values give the numbers. The
values come from the servo table as last read; temperature, voltage and limits are read at their
own ``pub_ratio``, so they may be a few loops old.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import units
from . import error_state
from .table import ServoTable

OK, WARN, ERROR = 0, 1, 2  # the levels of diagnostic_msgs/DiagnosticStatus
#: WARN when the temperature is this close to temperature_limit [degC] (ERROR at or above it)
TEMPERATURE_MARGIN_C = 5.0
#: WARN when the input voltage is this close to a voltage limit [V] (ERROR outside the limits)
VOLTAGE_MARGIN_V = 0.5
#: bus success rate (share of transactions some servo answered) below which the bus WARNs / ERRORs
SUCCESS_WARN, SUCCESS_ERROR = 0.9, 0.5
#: loop rate below this share of loop_rate WARNs (the loop cannot keep up)
LOOP_RATE_WARN = 0.8


@dataclass
class Health:
    """One status: level, a short message, and (key, value) pairs for the details."""

    name: str
    hardware_id: str
    level: int = OK
    problems: list[str] = field(default_factory=list)
    values: list[tuple[str, str]] = field(default_factory=list)

    def raise_to(self, level: int, problem: str) -> None:
        self.level = max(self.level, level)
        self.problems.append(problem)

    @property
    def message(self) -> str:
        return "; ".join(self.problems) if self.problems else "OK"


def _value(table: ServoTable, item: str, pos: int) -> float:
    return float(table.units(item)[pos])


def servo_health(table: ServoTable, dxl_id: int, prefix: str = "dynamixel_handler") -> Health:
    """Ping, hardware errors, temperature vs its limit, input voltage vs its limits, torque."""
    pos = table.index[dxl_id]
    model = table.models[pos]
    h = Health(name=f"{prefix}: ID {dxl_id} ({model.name})", hardware_id=f"dynamixel_id_{dxl_id}")
    _check_ping(h, table, pos)
    _check_hardware_error(h, table, dxl_id)
    _check_temperature(h, table, pos)
    _check_voltage(h, table, pos)
    _add_state(h, table, dxl_id)
    return h


def _check_ping(h: Health, table: ServoTable, pos: int) -> None:
    ping = bool(table.ping[pos])
    h.values.append(("ping", str(ping).lower()))
    if not ping:
        h.raise_to(ERROR, f"no response for {int(table.no_response[pos])} read(s): check power and wiring")


def _check_hardware_error(h: Health, table: ServoTable, dxl_id: int) -> None:
    model = table.model(dxl_id)
    value = table.value(error_state.error_item(model), dxl_id)  # bits, or a Y error code
    what = "unknown" if value is None else error_state.describe(model, value)
    h.values.append(("hardware error", what))
    bits = model.family.behaviour.hardware_bits(value or 0)
    if error_state.is_error(model, value):
        causes = [name for name, flag in units.decode_hardware_error([bits or 0]).items() if flag[0]]
        h.raise_to(ERROR, f"hardware error: {', '.join(causes) or what} (clear it with clear_error)")
    elif value:  # a warning code (Y battery warning): the servo runs on
        h.raise_to(WARN, f"{what}")


def _check_temperature(h: Health, table: ServoTable, pos: int) -> None:
    temp, temp_limit = _value(table, "present_temperature", pos), _value(table, "temperature_limit", pos)
    h.values.append(("temperature [degC]", _fmt(temp)))
    h.values.append(("temperature limit [degC]", _fmt(temp_limit)))
    if not (math.isfinite(temp) and math.isfinite(temp_limit)):
        return
    if temp >= temp_limit:
        h.raise_to(ERROR, f"overheating: {temp:g} degC at or above the limit {temp_limit:g} degC")
    elif temp >= temp_limit - TEMPERATURE_MARGIN_C:
        h.raise_to(WARN, f"hot: {temp:g} degC, within {TEMPERATURE_MARGIN_C:g} degC of the limit {temp_limit:g} degC")


def _check_voltage(h: Health, table: ServoTable, pos: int) -> None:
    volt = _value(table, "present_input_voltage", pos)
    v_min, v_max = _value(table, "min_voltage_limit", pos), _value(table, "max_voltage_limit", pos)
    h.values.append(("input voltage [V]", _fmt(volt)))
    h.values.append(("voltage limits [V]", f"{_fmt(v_min)}..{_fmt(v_max)}"))
    if not (math.isfinite(volt) and math.isfinite(v_min) and math.isfinite(v_max)):
        return
    if volt < v_min or volt > v_max:
        h.raise_to(ERROR, f"input voltage {volt:.1f} V outside the limits {v_min:.1f}..{v_max:.1f} V")
    elif volt < v_min + VOLTAGE_MARGIN_V or volt > v_max - VOLTAGE_MARGIN_V:
        h.raise_to(WARN, f"input voltage {volt:.1f} V close to the limits {v_min:.1f}..{v_max:.1f} V")


def _add_state(h: Health, table: ServoTable, dxl_id: int) -> None:
    """Torque and operating mode as last read: values only, they are no problem by themselves."""
    torque = table.value("torque_enable", dxl_id)
    h.values.append(("torque", "unknown" if torque is None else ("on" if torque else "off")))
    mode = table.value("operating_mode", dxl_id)
    h.values.append(("operating mode", "unknown" if mode is None else str(mode)))


@dataclass
class BusSample:
    """What the bus status is computed from, over the period since the previous status."""

    device: str
    elapsed_s: float
    loops: int
    target_rate_hz: float
    transactions: int
    success_rate: float
    device_lost: bool
    reconnects_total: int
    reconnects_new: int
    watchdog_trips_total: int
    watchdog_trips_new: int
    servos: int
    servos_silent: int
    #: why the E-stop is engaged (None: released)
    e_stop: str | None = None


def bus_health(s: BusSample, prefix: str = "dynamixel_handler") -> Health:
    """Success rate, loop rate vs target, reconnects, watchdog trips and the E-stop of one bus."""
    h = Health(name=f"{prefix}: bus {s.device}", hardware_id=s.device)
    rate = s.loops / s.elapsed_s if s.elapsed_s > 0 else float("nan")
    h.values += [("success rate [%]", f"{100 * s.success_rate:.1f}"), ("transactions", str(s.transactions)),
                 ("loop rate [Hz]", _fmt(rate, 1)), ("target loop rate [Hz]", _fmt(s.target_rate_hz)),
                 ("reconnects", str(s.reconnects_total)), ("watchdog trips", str(s.watchdog_trips_total)),
                 ("servos", str(s.servos)), ("servos not answering", str(s.servos_silent)),
                 ("e-stop", "released" if s.e_stop is None else f"engaged: {s.e_stop}")]
    _check_e_stop(h, s)
    if s.device_lost:
        h.raise_to(ERROR, f"{s.device} is gone: reconnecting")
    if s.transactions and s.success_rate < SUCCESS_ERROR:
        h.raise_to(ERROR, f"only {100 * s.success_rate:.0f}% of transactions answered")
    elif s.transactions and s.success_rate < SUCCESS_WARN:
        h.raise_to(WARN, f"{100 * s.success_rate:.0f}% of transactions answered: check wiring, baud rate, latency")
    if math.isfinite(rate) and rate < LOOP_RATE_WARN * s.target_rate_hz:
        h.raise_to(WARN, f"loop at {rate:.1f} Hz, below the target {s.target_rate_hz:g} Hz: lower loop_rate or read less")
    if s.reconnects_new:
        h.raise_to(WARN, f"reconnected {s.reconnects_new} time(s) since the last report")
    if s.watchdog_trips_new:
        h.raise_to(WARN, f"bus watchdog tripped {s.watchdog_trips_new} time(s) since the last report")
    return h


def _check_e_stop(h: Health, s: BusSample) -> None:
    if s.e_stop is not None:
        h.raise_to(WARN, f"E-stop engaged ({s.e_stop}): every servo holds, moving commands are refused")


def silent_count(table: ServoTable) -> int:
    return int(np.count_nonzero(~table.ping))


def _fmt(value: float, digits: int | None = None) -> str:
    if not math.isfinite(value):
        return "unknown"
    return f"{value:.{digits}f}" if digits is not None else f"{value:g}"
