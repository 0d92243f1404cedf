"""The node's parameter surface: names, types, defaults, meaning and validation (ROS-free).

Names are the interface of the original handler: a YAML file written for it loads unchanged. In a
ROS parameter file a nested map becomes a dotted name, so ``pub_ratio/present: {pwm: 2}`` is the
parameter ``pub_ratio/present.pwm``. The ROS layer (``ros/params.py``) declares every entry of
``SCHEMA`` with its type and reads the values back into a :class:`Config`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

from .config_checks import DUMMY_SERIES, USED_FAMILIES, check_values
from .control_table import FAMILIES, PROTOCOL1_FAMILIES, protocol1_models
from .errors import ConfigError
from .joints import EFFORT_UNITS, JointMap, is_joint_parameter, joint_map, merged
from .logs import cut
from .servo.settings import servo_block
from .settings import (
    GROUP_RATIOS,
    LOGGED_READS,
    LOGGED_WRITES,
    PRESENT_RATIOS,
    BusSettings,
    ExternalPortSettings,
    LogSettings,
    LoopSettings,
    Method,
    ReadRatios,
    RosSettings,
    SafetySettings,
    ScanSettings,
    Settings,
    StartValues,
    TermSettings,
    TrajectorySettings,
)

# Parameter types, as ROS knows them.
BOOL, INT, FLOAT, STR, INT_ARRAY, FLOAT_ARRAY = "bool", "int", "float", "str", "int[]", "float[]"
STR_ARRAY = "str[]"
#: the models of each Protocol 1.0 family, for the parameters' descriptions
_PROTOCOL1_NAMES = {f.name: [m.name for m in protocol1_models() if m.family is f] for f in PROTOCOL1_FAMILIES}


@dataclass(frozen=True)
class Param:
    name: str
    type: str
    default: Any
    description: str


def _p(name: str, type_: str, default: Any, description: str) -> Param:
    return Param(name, type_, default, description)


_PRESENT_ITEMS = PRESENT_RATIOS
_READ_GROUPS = LOGGED_READS

SCHEMA: tuple[Param, ...] = (
    _p("device_name", STR, "/dev/ttyUSB0", "serial device of the bus (U2D2 / USB-RS485 adapter)"),
    _p("baudrate", INT, 57600, "bus baud rate [bps]"),
    _p("latency_timer", INT, 16, "USB adapter latency timer [ms]; sets the reply timeouts"),
    _p("dyn_comm/retry_num", INT, 5, "retries of a failed bus transaction"),
    _p("dyn_comm/inerval_msec", INT, 4, "wait between retries [ms] (name kept as in the original handler)"),
    _p("dyn_comm/verbose", BOOL, False, "log every failed transaction"),
    _p("init/dummy_servo_list", INT_ARRAY, [-1], "IDs handled as dummy servos without hardware (-1: none)"),
    _p("init/dummy_servo_series", STR_ARRAY, [""],
       "series of the dummy servos: X, P or Pro, one for all or one per ID of dummy_servo_list (\"\": the first used series)"),
    _p("init/baudrate_auto_set", BOOL, False, "at start-up, find servos at other baud rates and set them to `baudrate`"),
    *(_p(f"init/used_servo_series.{f.title}", BOOL, f.used_by_default, f"handle {f.title} series servos")
      for f in FAMILIES),
    *(_p(f"init/used_servo_series.{f.title}", BOOL, False,
         f"handle {f.title} series servos (Protocol 1.0: {', '.join(_PROTOCOL1_NAMES[f.name])})")
      for f in PROTOCOL1_FAMILIES),
    _p("init/expected_servo_num", INT, 0, "servos the scan must find (0: at least one)"),
    _p("init/servo_auto_search.min_id", INT, 0, "lowest ID scanned"),
    _p("init/servo_auto_search.max_id", INT, 10, "highest ID scanned"),
    _p("init/servo_auto_search.retry_times", INT, 0, "scan repetitions until expected_servo_num servos answer"),
    _p("init/hardware_error_auto_clean", BOOL, True, "clear hardware errors (reboot) at start-up"),
    _p("init/torque_auto_enable", BOOL, True, "enable torque (safely) at start-up"),
    _p("term/torque_auto_disable", BOOL, True, "disable torque on shutdown"),
    _p("term/servo_auto_stop", BOOL, True, "stop servos in pwm/current/velocity mode on shutdown"),
    _p("safety/on_hardware_error", STR, "none",
       "what a hardware error of one servo does to the others: none (they go on) or hold_all (the E-stop engages)"),
    _p("led_status", BOOL, False, "each servo's LED shows its state: hardware error, E-stop, torque on, torque off "
       "(RGB: red, yellow, green, blue; one LED: on for an error or the E-stop)"),
    _p("default/profile_acc", FLOAT, 6008.0, "profile acceleration set at start-up [deg/s^2]"),
    _p("default/profile_vel", FLOAT, 1000.0, "profile velocity set at start-up [deg/s]"),
    _p("default/return_delay_time", FLOAT, 0.0, "return delay time set at start-up [us]"),
    _p("default/bus_watchdog", FLOAT, 500.0, "bus watchdog used by servo_auto_stop [ms] (0: off)"),
    _p("loop_rate", INT, 100, "main loop rate [Hz]"),
    _p("verbose_ratio", INT, 300, "log loop statistics every this many loops, at most once a second (0: only the one every 10 s)"),
    _p("pub_outdated_present_value", BOOL, True, "publish present items not read in this loop with their last value"),
    *(_p(f"pub_ratio/present.{k}", INT, v, f"read present {k} every this many loops (0: once at start)")
      for k, v in _PRESENT_ITEMS.items()),
    _p("pub_ratio/status", INT, 47, "read/publish status every this many loops (0: once at start)"),
    _p("pub_ratio/goal", INT, 11, "read/publish goal values every this many loops (0: once at start)"),
    _p("pub_ratio/gain", INT, 101, "read/publish gains every this many loops (0: once at start)"),
    _p("pub_ratio/limit", INT, 307, "read/publish limits every this many loops (0: once at start)"),
    _p("pub_ratio/error", INT, 53, "read/publish hardware errors every this many loops (0: once at start)"),
    _p("pub_ratio/extra.dynamic_items", INT, 31, "read changing extra items every this many loops (0: once)"),
    _p("pub_ratio/extra.static_items", INT, 407, "read fixed extra items every this many loops (0: once)"),
    _p("method/fast_read", BOOL, False, "use Fast Sync Read (needs recent servo firmware)"),
    _p("method/split_read", BOOL, False, "one sync read per item instead of one contiguous read"),
    _p("method/split_write", BOOL, True, "one sync write per item instead of one contiguous write"),
    _p("option/external_port.use", BOOL, False, "enable external port topics (X540, P, Pro)"),
    _p("option/external_port.pub_ratio/data", INT, 10, "read external port data every this many loops"),
    _p("option/external_port.pub_ratio/mode", INT, 100, "read external port modes every this many loops"),
    _p("option/external_port.verbose/callback", BOOL, False, "log external port commands"),
    _p("option/external_port.verbose/write", BOOL, False, "log external port writes"),
    _p("option/external_port.verbose/read.raw", BOOL, False, "log external port reads"),
    _p("option/external_port.verbose/read.err", BOOL, False, "log failed external port reads"),
    _p("option/imu_opencr.use", BOOL, False, "OpenCR IMU (not supported by this handler; accepted for YAML compatibility)"),
    _p("option/imu_opencr.pub_ratio", INT, 2, "OpenCR IMU read ratio (unused)"),
    _p("option/imu_opencr.opencr_id", INT, 40, "OpenCR ID (unused)"),
    _p("option/imu_opencr.model_number", INT, 0, "OpenCR model number (unused)"),
    _p("option/imu_opencr.frame_id", STR, "base_link", "IMU frame (unused)"),
    _p("option/imu_opencr.adjust/rpy_deg", FLOAT_ARRAY, [0.0, 0.0, 180.0], "IMU mounting rotation (unused)"),
    _p("option/imu_opencr.adjust/flip_z_axis", BOOL, True, "IMU z flip (unused)"),
    _p("max_log_width", INT, 6, "IDs per line in list-like logs"),
    _p("verbose/callback", BOOL, False, "log every accepted command"),
    *(_p(f"verbose/write_{g}", BOOL, False, f"log {g} writes") for g in LOGGED_WRITES),
    *(_p(f"verbose/read_{g}.{k}", BOOL, False, f"log {g} reads ({'values' if k == 'raw' else 'failures'})")
      for g in _READ_GROUPS for k in ("raw", "err")),
    _p("verbose/read_hardware_error", BOOL, True, "log hardware errors when read"),
    _p("debug", BOOL, False, "keep running without a device (topics only, for development)"),
    _p("no_use_command_line", BOOL, False, "do not create the command-line topics (/dynamixel/state/*, /dynamixel/command/*)"),
    _p("no_response_id_auto_remove_count", INT, 0, "remove a servo after this many loops without reply (0: never)"),
    _p("mode_change_interval_sec", FLOAT, 1.0, "least time between two mode changes of one servo [s]"),
    _p("clear_error_interval_sec", FLOAT, 1.0, "least time between two error clears of one servo [s]"),
    _p("joint_state.use", BOOL, False, "publish sensor_msgs/JointState on joint_states for the mapped servos"),
    _p("joint_state.names", STR_ARRAY, [""], "joint names, aligned with joint_state.ids ([\"\"]: no mapping)"),
    _p("joint_state.ids", INT_ARRAY, [-1], "servo ID of each joint name ([-1]: no mapping)"),
    _p("joint_state.directions", INT_ARRAY, [1], "+1/-1 per joint (one value: every joint); joint = dir*(servo-offset)"),
    _p("joint_state.effort_unit", STR, "A", "the joints' effort: A (the present current, as measured) or Nm (the "
       "current times the model's e-Manual torque per ampere and the joint's reduction: an approximation)"),
    _p("joint_state.offsets_deg", FLOAT_ARRAY, [0.0], "servo angle at the joint's zero [deg] per joint (one value: every joint)"),
    _p("diagnostics.period_sec", FLOAT, 1.0, "publish diagnostic_msgs/DiagnosticArray on /diagnostics every this many seconds (0: off)"),
    _p("trajectory.path_tolerance_deg", FLOAT, 0.0,
       "joint trajectories: largest distance from the path while running, unless the goal gives one [deg] (0: not checked)"),
    _p("trajectory.goal_tolerance_deg", FLOAT, 1.0,
       "joint trajectories: largest distance from the last point at the end, unless the goal gives one [deg] (0: not checked)"),
    _p("trajectory.goal_time_sec", FLOAT, 1.0,
       "joint trajectories: time allowed after the end to come within the goal tolerance, unless the goal gives one [s]"),
    _p("joints_calibration.path", STR, "", "file the service dynamixel/calibrate_offsets saves the joints' offsets "
       "to, loaded at start over the parameters' offsets (\"\": offsets set until the node stops, not saved)"),
    _p("servos_snapshot.path", STR, "", "file the service dynamixel/save_servo_settings writes the servos block to "
       "(\"\": dynamixel_servos.yaml in the ROS log directory)"),
)
SCHEMA_BY_NAME: dict[str, Param] = {p.name: p for p in SCHEMA}

# Prefixes whose unknown keys are accepted silently: the original handler's OpenCR IMU option
# has more keys than this handler reads.
TOLERATED_PREFIXES = ("option/imu_opencr.",)

# Other spellings of parameters found in the original handler's YAML files (older versions of
# them among others): the value goes to the parameter(s) on the right unless those are given too.
ALIASES: dict[str, tuple[str, ...]] = {
    "dummy_servo_id_list": ("init/dummy_servo_list",),
    "pub_ratio/extra": ("pub_ratio/extra.dynamic_items", "pub_ratio/extra.static_items"),
    **{f"verbose/read_{g}/{k}": (f"verbose/read_{g}.{k}",) for g in _READ_GROUPS for k in ("raw", "err")},
    **{f"option/external_port.verbose/read/{k}": (f"option/external_port.verbose/read.{k}",) for k in ("raw", "err")},
}


def coerce(param: Param, value: Any) -> Any:
    """Return ``value`` as ``param``'s type, or raise ConfigError (ints pass as floats and back
    when integral, so `loop_rate: 100.0` and `profile_vel: 1000` both load)."""
    convert = _COERCERS.get(param.type)
    if convert is None:
        raise _wrong_type(param, value)
    return convert(param, value)


def _wrong_type(param: Param, value: Any) -> ConfigError:
    return ConfigError(f"parameter '{param.name}' must be {param.type}, got {value!r} ({type(value).__name__})")


def _as_bool(param: Param, value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise _wrong_type(param, value)


def _as_int(param: Param, value: Any) -> int:
    if isinstance(value, bool):
        raise _wrong_type(param, value)
    if isinstance(value, int):
        return value
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        return int(value)
    raise _wrong_type(param, value)


def _as_float(param: Param, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _wrong_type(param, value)
    return float(value)


def _as_str(param: Param, value: Any) -> str:
    if isinstance(value, str):
        return value
    raise _wrong_type(param, value)


#: array type -> the type of its elements
_ELEMENT_TYPES = {INT_ARRAY: INT, FLOAT_ARRAY: FLOAT, STR_ARRAY: STR}


def _as_list(param: Param, value: Any) -> list[Any]:
    """Each element coerced to the array's element type; an element at fault is named ``<name>[]``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise _wrong_type(param, value)
    elem = Param(param.name + "[]", _ELEMENT_TYPES[param.type], None, "")
    return [coerce(elem, v) for v in value]


_COERCERS: dict[str, Callable[[Param, Any], Any]] = {
    BOOL: _as_bool, INT: _as_int, FLOAT: _as_float, STR: _as_str,
    INT_ARRAY: _as_list, FLOAT_ARRAY: _as_list, STR_ARRAY: _as_list,
}


@dataclass(frozen=True)
class Config:
    """Validated parameter values, looked up by their parameter names (the ROS side), and the
    same values as typed :class:`~dynamixel_handler.settings.Settings` (``settings``, the core)."""

    values: Mapping[str, Any] = field(default_factory=dict)
    settings: Settings = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", settings_of(self.values))

    def __getitem__(self, name: str) -> Any:
        return self.values[name]


def _used_series(v: Mapping[str, Any]) -> tuple[str, ...]:
    return tuple(f.name for f in USED_FAMILIES if v[f"init/used_servo_series.{f.title}"])


def _dummy_ids(v: Mapping[str, Any]) -> list[int]:
    return [i for i in v["init/dummy_servo_list"] if 0 <= i <= 252]


def _dummy_series(v: Mapping[str, Any]) -> list[str]:
    used = _used_series(v)
    given = [DUMMY_SERIES[s.strip().lower()] or (used[0] if used else "")
             for s in v.get("init/dummy_servo_series", [""])]
    ids = [i for i in v["init/dummy_servo_list"] if i != -1]
    per_id = given if len(given) == len(ids) else [given[0]] * len(ids)
    return [s for i, s in zip(ids, per_id) if 0 <= i <= 252]


#: group of ``settings.GROUP_RATIOS`` -> the parameter holding its ratio
GROUP_RATIO_PARAMS: Mapping[str, str] = {
    "status": "pub_ratio/status", "goal": "pub_ratio/goal", "gain": "pub_ratio/gain",
    "limit": "pub_ratio/limit", "error": "pub_ratio/error",
    "extra_dynamic": "pub_ratio/extra.dynamic_items", "extra_static": "pub_ratio/extra.static_items",
}
assert set(GROUP_RATIO_PARAMS) == set(GROUP_RATIOS)


def settings_of(values: Mapping[str, Any]) -> Settings:
    """The typed settings of a complete set of parameter values: the one place that says which
    parameter feeds which field (values missing from ``values`` take their defaults)."""
    v = {**defaults(), **values}
    ext = "option/external_port."
    return Settings(
        bus=BusSettings(device=v["device_name"], baudrate=v["baudrate"], latency_ms=v["latency_timer"],
                        retries=v["dyn_comm/retry_num"], retry_interval_ms=float(v["dyn_comm/inerval_msec"]),
                        verbose=v["dyn_comm/verbose"]),
        scan=ScanSettings(min_id=v["init/servo_auto_search.min_id"], max_id=v["init/servo_auto_search.max_id"],
                          retry_times=v["init/servo_auto_search.retry_times"], expected=v["init/expected_servo_num"],
                          used_series=_used_series(v), baudrate_auto_set=v["init/baudrate_auto_set"],
                          hardware_error_auto_clean=v["init/hardware_error_auto_clean"],
                          torque_auto_enable=v["init/torque_auto_enable"], dummy_ids=tuple(_dummy_ids(v)),
                          dummy_series=tuple(_dummy_series(v)),
                          ignored_dummy_ids=tuple(i for i in v["init/dummy_servo_list"] if i != -1 and not 0 <= i <= 252)),
        start=StartValues(profile_acc=v["default/profile_acc"], profile_vel=v["default/profile_vel"],
                          return_delay_time=v["default/return_delay_time"], bus_watchdog_ms=v["default/bus_watchdog"]),
        term=TermSettings(torque_auto_disable=v["term/torque_auto_disable"], servo_auto_stop=v["term/servo_auto_stop"]),
        safety=SafetySettings(on_hardware_error=v["safety/on_hardware_error"].strip().lower(), led_status=v["led_status"]),
        loop=LoopSettings(rate_hz=v["loop_rate"], verbose_ratio=v["verbose_ratio"],
                          no_response_auto_remove=v["no_response_id_auto_remove_count"],
                          mode_change_interval_s=float(v["mode_change_interval_sec"]),
                          clear_error_interval_s=float(v["clear_error_interval_sec"]), debug=v["debug"]),
        ratios=ReadRatios(present={k: int(v[f"pub_ratio/present.{k}"]) for k in PRESENT_RATIOS},
                          groups={g: int(v[p]) for g, p in GROUP_RATIO_PARAMS.items()},
                          outdated_present=v["pub_outdated_present_value"]),
        method=Method(fast_read=v["method/fast_read"], split_read=v["method/split_read"],
                      split_write=v["method/split_write"]),
        logs=LogSettings(max_width=v["max_log_width"], callback=v["verbose/callback"],
                         writes=frozenset(g for g in LOGGED_WRITES if v[f"verbose/write_{g}"]),
                         reads_raw=frozenset(g for g in LOGGED_READS if v[f"verbose/read_{g}.raw"]),
                         reads_err=frozenset(g for g in LOGGED_READS if v[f"verbose/read_{g}.err"]),
                         hardware_error=v["verbose/read_hardware_error"]),
        external_port=ExternalPortSettings(
            use=v[ext + "use"], data_ratio=v[ext + "pub_ratio/data"], mode_ratio=v[ext + "pub_ratio/mode"],
            verbose_callback=v[ext + "verbose/callback"], verbose_write=v[ext + "verbose/write"],
            verbose_read=v[ext + "verbose/read.raw"], verbose_err=v[ext + "verbose/read.err"]),
        trajectory=TrajectorySettings(path_tolerance_deg=float(v["trajectory.path_tolerance_deg"]),
                                      goal_tolerance_deg=float(v["trajectory.goal_tolerance_deg"]),
                                      goal_time_s=float(v["trajectory.goal_time_sec"])),
        ros=RosSettings(command_line=not v["no_use_command_line"], diagnostics_period_s=float(v["diagnostics.period_sec"]),
                        joint_state_use=_joint_state_use(v), joints=_joints(v),
                        snapshot_path=v["servos_snapshot.path"], calibration_path=v["joints_calibration.path"]),
        servos=servo_block(v, _joints(v)))


def _joint_state_use(v: Mapping[str, Any]) -> bool:
    """joint_states and the joint doors: ``joint_state.use``, or a joints block given."""
    return bool(v["joint_state.use"]) or any(map(is_joint_parameter, v))


def _joints(v: Mapping[str, Any]) -> JointMap | None:
    """The joint_state.* mapping and the joints block's (ConfigError naming the parameter at fault)."""
    block = any(is_joint_parameter(name) for name in v)
    simple = joint_map(v["joint_state.use"] and not block, v["joint_state.names"], v["joint_state.ids"],
                       v["joint_state.directions"], v["joint_state.offsets_deg"])
    mapping = merged(simple, v)
    unit = EFFORT_UNITS.get(str(v["joint_state.effort_unit"]).strip().lower())
    if unit is None:
        raise ConfigError(f"parameter 'joint_state.effort_unit' = '{cut(str(v['joint_state.effort_unit']))}': A or Nm")
    return None if mapping is None else replace(mapping, effort_unit=unit)


def validate(values: Mapping[str, Any]) -> Config:
    """Check ranges and relations; raise ConfigError with one clear line for the first problem."""
    v = dict(values)
    check_values(v)
    _joints(v)  # raises ConfigError naming the joint_state parameter at fault
    return Config(v)


def defaults() -> dict[str, Any]:
    return {p.name: p.default for p in SCHEMA}
