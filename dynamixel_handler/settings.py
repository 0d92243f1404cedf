"""The handler's settings as typed, frozen values, one dataclass per concern (ROS-free).

The core reads these, never parameter names: ``config.settings_of`` builds a :class:`Settings`
once from the validated parameters (the only place that knows which parameter feeds which
field), and plain Python builds one directly, every field defaulting to the parameter's default::

    Settings(bus=BusSettings(device="/dev/ttyUSB0", baudrate=1_000_000),
             scan=ScanSettings(min_id=1, max_id=4, expected=4))

Values are not checked here; ``config.validate`` checks the parameters the node loads.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Mapping

from .joints import JointMap
from .servo.settings import ServoSetting

#: present item keys (``pub_ratio/present.<key>``) -> default ratio
PRESENT_RATIOS: Mapping[str, int] = {
    "pwm": 2, "current": 2, "velocity": 2, "position": 2,
    "velocity_trajectory": 0, "position_trajectory": 0, "input_voltage": 29, "temperature": 29,
}
#: read groups (``groups.GROUP_ITEMS``) -> default ratio
GROUP_RATIOS: Mapping[str, int] = {
    "status": 47, "goal": 11, "gain": 101, "limit": 307, "error": 53, "extra_dynamic": 31, "extra_static": 407,
}
#: groups whose writes and reads can be logged (``verbose/write_<group>``, ``verbose/read_<group>.raw|err``)
LOGGED_WRITES = ("status", "goal", "gain", "limit", "extra")
LOGGED_READS = ("status", "present", "goal", "gain", "limit", "extra")


@dataclass(frozen=True)
class BusSettings:
    """The serial line and its transactions."""

    device: str = "/dev/ttyUSB0"
    baudrate: int = 57600
    latency_ms: int = 16               #: the USB adapter's latency timer
    retries: int = 5                   #: retries of a failed transaction
    retry_interval_ms: float = 4.0     #: wait between retries
    verbose: bool = False              #: log every failed transaction


@dataclass(frozen=True)
class ScanSettings:
    """Start-up: which servos are looked for and how they are set up."""

    min_id: int = 0
    max_id: int = 10
    retry_times: int = 0               #: scan repetitions until ``expected`` servos answer
    expected: int = 0                  #: servos the scan must find (0: at least one)
    used_series: tuple[str, ...] = ("X",)  #: "X", "P", "PRO"
    baudrate_auto_set: bool = False
    hardware_error_auto_clean: bool = True
    torque_auto_enable: bool = True
    dummy_ids: tuple[int, ...] = ()
    dummy_series: tuple[str, ...] = ()  #: the series of each of ``dummy_ids``
    ignored_dummy_ids: tuple[int, ...] = ()  #: of init/dummy_servo_list, those outside 0..252


@dataclass(frozen=True)
class StartValues:
    """Values written to every servo at start-up."""

    profile_acc: float = 6008.0        #: [deg/s^2]
    profile_vel: float = 1000.0        #: [deg/s]
    return_delay_time: float = 0.0     #: [us]
    bus_watchdog_ms: float = 500.0     #: used by ``TermSettings.servo_auto_stop`` (0: off)


@dataclass(frozen=True)
class TermSettings:
    """What shutdown leaves the servos as."""

    torque_auto_disable: bool = True
    servo_auto_stop: bool = True


#: what a hardware error of one servo does to the others (``safety/on_hardware_error``)
ON_HARDWARE_ERROR = ("none", "hold_all")


@dataclass(frozen=True)
class SafetySettings:
    """What a fault of one servo does to the others."""

    #: "none" (the others go on, as the original handler) or "hold_all" (the E-stop engages)
    on_hardware_error: str = "none"
    #: each servo's LED shows its state (error, E-stop, torque on, torque off)
    led_status: bool = False


@dataclass(frozen=True)
class LoopSettings:
    """The loop's rate and its rules over time."""

    rate_hz: float = 100               #: [Hz] (the node gives the integer loop_rate)
    verbose_ratio: int = 300           #: log statistics every this many loops (0: every 10 s only)
    no_response_auto_remove: int = 0  #: loops without reply before a servo is removed (0: never)
    mode_change_interval_s: float = 1.0
    clear_error_interval_s: float = 1.0
    debug: bool = False                #: keep running without a device


@dataclass(frozen=True)
class ReadRatios:
    """Every how many loops each item is read (0: once at start)."""

    present: Mapping[str, int] = field(default_factory=lambda: dict(PRESENT_RATIOS))
    groups: Mapping[str, int] = field(default_factory=lambda: dict(GROUP_RATIOS))
    outdated_present: bool = True      #: publish present items not read this loop with their last value

    def __post_init__(self) -> None:  # read-only views: the settings are replaced as a whole, never changed
        object.__setattr__(self, "present", MappingProxyType(dict(self.present)))
        object.__setattr__(self, "groups", MappingProxyType(dict(self.groups)))

    def all(self) -> tuple[int, ...]:
        """Every ratio, present keys first then groups."""
        return (*self.present.values(), *self.groups.values())


@dataclass(frozen=True)
class Method:
    """How the bus is read and written."""

    fast_read: bool = False
    split_read: bool = False
    split_write: bool = True


@dataclass(frozen=True)
class LogSettings:
    """Which lines the core logs."""

    max_width: int = 6                 #: IDs per line in list-like logs
    callback: bool = False             #: every accepted command
    writes: frozenset[str] = frozenset()      #: groups of ``LOGGED_WRITES`` whose writes are logged
    reads_raw: frozenset[str] = frozenset()   #: groups of ``LOGGED_READS`` whose values are logged
    reads_err: frozenset[str] = frozenset()   #: groups of ``LOGGED_READS`` whose failures are logged
    hardware_error: bool = True        #: hardware errors when read


@dataclass(frozen=True)
class ExternalPortSettings:
    """The external ports of X540, P and Pro servos."""

    use: bool = False
    data_ratio: int = 10
    mode_ratio: int = 100
    verbose_callback: bool = False
    verbose_write: bool = False
    verbose_read: bool = False
    verbose_err: bool = False


@dataclass(frozen=True)
class TrajectorySettings:
    """Defaults of joint trajectories (a goal's own values win)."""

    path_tolerance_deg: float = 0.0
    goal_tolerance_deg: float = 1.0
    goal_time_s: float = 1.0


@dataclass(frozen=True)
class RosSettings:
    """What only the ROS layer reads: its optional topics and the joint mapping."""

    command_line: bool = True          #: the /dynamixel/state/*, /dynamixel/command/* topics
    diagnostics_period_s: float = 1.0  #: /diagnostics every this many seconds (0: off)
    joint_state_use: bool = False      #: joint_states and joint_commands for the mapped servos
    joints: JointMap | None = None     #: the joint_state.* mapping (never None with joint_state_use)
    snapshot_path: str = ""            #: where dynamixel/save_servo_settings writes ("": the ROS log directory)
    calibration_path: str = ""         #: where dynamixel/calibrate_offsets saves ("": not saved)


@dataclass(frozen=True)
class Settings:
    """Everything the ROS-free handler, runner and commander read."""

    bus: BusSettings = BusSettings()
    scan: ScanSettings = ScanSettings()
    start: StartValues = StartValues()
    term: TermSettings = TermSettings()
    safety: SafetySettings = SafetySettings()
    loop: LoopSettings = LoopSettings()
    ratios: ReadRatios = field(default_factory=ReadRatios)
    method: Method = Method()
    logs: LogSettings = LogSettings()
    external_port: ExternalPortSettings = ExternalPortSettings()
    trajectory: TrajectorySettings = TrajectorySettings()
    ros: RosSettings = RosSettings()
    #: the parameters file's ``servos`` block: per-servo mode, gains, limits, profiles...
    servos: tuple[ServoSetting, ...] = ()

    def but(self, **changes: object) -> Settings:
        """A copy with fields of the parts changed, each named ``part__field``::

            settings.but(scan__torque_auto_enable=False, loop__rate_hz=50)
        """
        parts: dict[str, dict[str, object]] = {}
        for name, value in changes.items():
            part, sep, key = name.partition("__")
            if not sep or part not in self.__dataclass_fields__:
                raise TypeError(f"Settings.but: '{name}' is not of the form part__field")
            parts.setdefault(part, {})[key] = value
        return replace(self, **{p: replace(getattr(self, p), **kv) for p, kv in parts.items()})
