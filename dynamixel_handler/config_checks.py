"""The ranges and relations of the parameters, checked before anything is started: one clear line
(``ConfigError``) naming the parameter at fault for the first problem (``config.validate``)."""
from __future__ import annotations

import math
from typing import Any, Mapping

from .bus.port import LINE_BAUDRATES as BAUDRATES  # the Protocol 2.0 rates and the Protocol 1.0-only ones
from .control_table import FAMILIES, PROTOCOL1_FAMILIES
from .errors import ConfigError
from .logs import cut
from .settings import ON_HARDWARE_ERROR

__all__ = ["DUMMY_SERIES", "USED_FAMILIES", "check_values"]

#: the families ``init/used_servo_series`` switches: the Protocol 2.0 ones, then the Protocol 1.0 ones
USED_FAMILIES = FAMILIES + PROTOCOL1_FAMILIES
#: a dummy's series as the parameter may spell it ("x", "Pro", ...) -> its name ("" : the first used)
DUMMY_SERIES = {"": "", **{f.title.lower(): f.name for f in FAMILIES}}


def check_values(v: Mapping[str, Any]) -> None:
    """Every check but the joint mapping's (``config._joints``), in the parameters' order."""
    _check_bus(v)
    _check_scan(v)
    _check_dummies_and_series(v)
    _check_loop(v)
    _check_start_values(v)
    _check_logs_and_options(v)


def _need(cond: bool, msg: str) -> None:
    if not cond:
        raise ConfigError(msg)


def _check_bus(v: Mapping[str, Any]) -> None:
    """Device, baud rate, latency timer and retries."""
    _need(bool(v["device_name"]), "parameter 'device_name' is empty: give the serial device, e.g. /dev/ttyUSB0")
    _need(v["baudrate"] in BAUDRATES,
          f"parameter 'baudrate' = {v['baudrate']} is not a Dynamixel baud rate; use one of {', '.join(map(str, BAUDRATES))}")
    _need(0 <= v["latency_timer"] <= 255, f"parameter 'latency_timer' = {v['latency_timer']} must be 0..255 ms")
    _need(v["dyn_comm/retry_num"] >= 0, "parameter 'dyn_comm/retry_num' must be >= 0")
    _need(v["dyn_comm/inerval_msec"] >= 0, "parameter 'dyn_comm/inerval_msec' must be >= 0")


def _check_scan(v: Mapping[str, Any]) -> None:
    """The ID range of the start-up scan, its repetitions and the servos it must find."""
    lo, hi = v["init/servo_auto_search.min_id"], v["init/servo_auto_search.max_id"]
    _need(0 <= lo <= 252 and 0 <= hi <= 252,
          f"parameters 'init/servo_auto_search.min_id/max_id' = {lo}/{hi} must be within 0..252")
    _need(lo <= hi, f"parameter 'init/servo_auto_search.max_id' ({hi}) is below min_id ({lo})")
    _need(v["init/servo_auto_search.retry_times"] >= 0, "parameter 'init/servo_auto_search.retry_times' must be >= 0")
    _need(v["init/expected_servo_num"] >= 0, "parameter 'init/expected_servo_num' must be >= 0")


def _check_dummies_and_series(v: Mapping[str, Any]) -> None:
    """Series names of the dummy servos (one for all or one per ID) and at least one used series."""
    series = v.get("init/dummy_servo_series", [""])
    bad = [s for s in series if s.strip().lower() not in DUMMY_SERIES]
    _need(not bad, f"parameter 'init/dummy_servo_series' has {bad[:3]}: use X, P or Pro")
    n_dummies = len([i for i in v["init/dummy_servo_list"] if i != -1])
    _need(len(series) in (1, n_dummies),
          f"parameter 'init/dummy_servo_series' has {len(series)} entries: give one for all dummies or one per "
          f"ID of init/dummy_servo_list ({n_dummies})")
    _need(any(v[f"init/used_servo_series.{f.title}"] for f in USED_FAMILIES),
          "parameters 'init/used_servo_series.{" + ",".join(f.title for f in USED_FAMILIES)
          + "}' are all false: enable at least one series")


def _check_loop(v: Mapping[str, Any]) -> None:
    """Loop rate, statistics ratio and every read ratio."""
    _need(0 < v["loop_rate"] <= 2000, f"parameter 'loop_rate' = {v['loop_rate']} must be 1..2000 Hz")
    _need(v["verbose_ratio"] >= 0, "parameter 'verbose_ratio' must be >= 0")
    for name, value in v.items():
        if name.startswith("pub_ratio/") or ".pub_ratio/" in name:
            _need(value >= 0, f"parameter '{name}' = {value} must be >= 0 (0 = read once at start)")


def _check_start_values(v: Mapping[str, Any]) -> None:
    """Values written at start-up and the least intervals between mode changes / error clears."""
    for name in ("default/profile_acc", "default/profile_vel", "default/return_delay_time", "default/bus_watchdog",
                 "mode_change_interval_sec", "clear_error_interval_sec"):
        _need_finite_non_negative(v, name)
    _need(v["default/return_delay_time"] <= 508, "parameter 'default/return_delay_time' must be <= 508 us")
    _need(v["default/bus_watchdog"] <= 2540, "parameter 'default/bus_watchdog' must be <= 2540 ms (127 x 20 ms)")


def _check_logs_and_options(v: Mapping[str, Any]) -> None:
    """Auto removal, log width, the hardware error rule, diagnostics period and the trajectory tolerances."""
    _need(v["no_response_id_auto_remove_count"] >= 0, "parameter 'no_response_id_auto_remove_count' must be >= 0")
    _need(v["max_log_width"] >= 1, "parameter 'max_log_width' must be >= 1")
    _need(v["safety/on_hardware_error"].strip().lower() in ON_HARDWARE_ERROR,
          f"parameter 'safety/on_hardware_error' = '{cut(v['safety/on_hardware_error'])}' is not one of "
          f"{', '.join(ON_HARDWARE_ERROR)}")
    _need(math.isfinite(v["diagnostics.period_sec"]) and v["diagnostics.period_sec"] >= 0,
          "parameter 'diagnostics.period_sec' must be a finite value >= 0 (0: off)")
    for name in ("trajectory.path_tolerance_deg", "trajectory.goal_tolerance_deg", "trajectory.goal_time_sec"):
        _need_finite_non_negative(v, name)


def _need_finite_non_negative(v: Mapping[str, Any], name: str) -> None:
    _need(math.isfinite(v[name]) and v[name] >= 0, f"parameter '{name}' = {v[name]} must be a finite value >= 0")
