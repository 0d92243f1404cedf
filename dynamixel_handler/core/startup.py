"""Start-up: the scan, the servos kept, the set-up each gets (also when added later)."""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable, Sequence

from .. import units
from ..bus import ServoBus, dummy_ids
from ..bus.ops import Ping
from ..control_table import POSITION_MODES
from ..errors import Interrupted, StartupError
from ..servo import error_state
from ..servo.settings import ServoSetting
from ..servo.table import ServoTable
from ..settings import ScanSettings, StartValues
from .deferred import Deferred
from .kept_settings import KeptSettings
from .log_limits import LogLimits
from .recovery import Recovery
from .scan import UNKNOWN_MODEL_HELP, Scan, Seen, lookup, none_handled
from .servo_io import Log, ServoIO
from .watchdog import Watchdog


@dataclass(frozen=True)
class StartupSettings:
    scan: ScanSettings = ScanSettings()     # which servos are looked for, how they are set up
    start: StartValues = StartValues()      # the values every servo gets
    debug: bool = False                     # a start-up problem is logged and the node runs on
    servos: tuple[ServoSetting, ...] = ()   # the parameters file's servos block


class Startup:
    """Scan, expected count, per-servo set-up, add_id. ``interrupted()`` tells that the node is
    asked to exit (the scan and the set-up stop between two servos)."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, io: ServoIO, eeprom: Deferred,
                 recovery: Recovery, watchdog: Watchdog, settings: StartupSettings,
                 interrupted: Callable[[], bool]) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.io = io
        self.eeprom = eeprom
        self.recovery = recovery
        self.watchdog = watchdog
        self.settings = settings
        self.interrupted = interrupted
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        #: ID -> handled or not, as commands asked in this loop (``want_handled``); None: nothing asked
        self.membership: dict[int, bool] | None = None
        #: whether start-up reached its first write (a refusal before it leaves every servo as found)
        self.wrote = False
        self.scanning = Scan(bus, log, settings.scan, self._startup_problem, interrupted)
        #: the servos block: checked after the scan, applied at each set-up, put back after a reset
        self.kept = KeptSettings(table, io, eeprom, watchdog, lambda: self.settings.servos,
                                 lambda level, msg: self.log.log(level, msg))

    def start(self) -> None:
        """Scan, keep the servos of the used series, and set each up as the parameters say."""
        self.wrote = False
        dummies = dummy_ids(self.bus)
        expected = self.settings.scan.expected
        self.scanning.settings = self.settings.scan
        found = self.scanning.scan(dummies, expected)
        self._keep(found, dummies)
        if expected > 0 and len(self.table) != expected:
            message = (f"handling {len(self.table)} servo(s) {list(self.table.ids)} on {self.bus.device}, but "
                       f"init/expected_servo_num is {expected}: check the IDs on the bus, or set "
                       "init/expected_servo_num (0: any number)")
            self._startup_problem(message)
        self.kept.check(self.settings.debug)  # before anything is written
        self.wrote = True
        for dxl_id in list(self.table.ids):
            if self.interrupted():
                raise Interrupted(f"start-up interrupted while setting up the servos (at ID {dxl_id})")
            self.setup_servo(dxl_id)

    def _keep(self, found: dict[int, Seen], dummies: Sequence[int]) -> None:
        """Put the servos found that are known models of a used series (or dummies) in the table."""
        used = set(self.settings.scan.used_series)
        for dxl_id, seen in sorted(found.items()):
            model = lookup(seen)
            if model is None:
                self.log.warning(f"ID {dxl_id}: unknown model number {seen[1]}"
                                 f"{' (Protocol 1.0)' if seen[0] == 1 else ''}, not handled: {UNKNOWN_MODEL_HELP}")
                continue
            if model.series not in used and dxl_id not in dummies:
                self.log.info(f"ID {dxl_id}: {model.name} is series {model.series}, which "
                              f"init/used_servo_series does not enable: skipped")
                continue
            self.table.add(dxl_id, model)
            kind = "dummy" if dxl_id in dummies else f"model {seen[1]}"
            self.log.info(f"ID {dxl_id}: {model.name} ({kind}, series {model.series}"
                          f"{', Protocol 1.0' if model.protocol == 1 else ''}) handled")
        if not len(self.table) and found and not self.settings.debug:
            none_handled(found, used)

    def _startup_problem(self, message: str) -> None:
        """Start-up cannot go on (StartupError), unless the debug parameter says to run on anyway."""
        if not self.settings.debug:
            raise StartupError(message)
        self.log.warning(message + " (debug: running on)")

    def setup_servo(self, dxl_id: int) -> None:
        """The set-up every servo gets, at start-up and when added later (add_id): hardware error
        cleared (init/hardware_error_auto_clean), the servos block's EEPROM items and mode, return
        delay, profile defaults, the block's RAM items, torque as init/torque_auto_enable says; the
        bus watchdog when the loop next runs. The block's items replace the defaults."""
        settings, model = self.settings, self.table.model(dxl_id)
        if settings.scan.hardware_error_auto_clean:
            self._clear_error(dxl_id)
        done = self.kept.prepare(dxl_id)
        if not self.kept.sets(dxl_id, "return_delay_time"):
            delay = int(units.unit_to_pulse([model], "return_delay_time", [settings.start.return_delay_time])[0])
            self.eeprom.write_eeprom(dxl_id, "return_delay_time", delay)
        self._setup_ram(dxl_id)
        self.kept.finish(dxl_id, done)
        if settings.scan.torque_auto_enable:
            self.io.torque_on(dxl_id)

    def _clear_error(self, dxl_id: int) -> None:
        """A hardware error at start-up cleared by reboot; an error code (Y) by its error clear."""
        model = self.table.model(dxl_id)
        err = self.io.read_item(dxl_id, error_state.error_item(model))
        if not error_state.is_error(model, err):
            return
        codes = model.family.error_codes
        if codes is not None and codes.clear_params is not None:
            self.log.warning(f"ID {dxl_id}: {error_state.describe(model, err or 0)} at start-up: clearing it")
            cleared = self.recovery.clear_error(dxl_id, params=codes.clear_params)
            if not cleared:
                self.log.warning(f"ID {dxl_id}: error not cleared: {cleared.why}")
            return
        self.log.warning(f"ID {dxl_id}: hardware error 0x{err or 0:02X} at start-up: clearing it by reboot")
        self.recovery.reboot(dxl_id)

    def _setup_ram(self, dxl_id: int) -> None:
        """Profile defaults now; the bus watchdog when the loop starts (arming it here, servo by
        servo, would let it trip on the first servos while the last ones are still set up)."""
        model = self.table.model(dxl_id)
        start = self.settings.start
        for item, limit, param, value in (
                ("profile_acceleration", "acceleration_limit", "default/profile_acc", start.profile_acc),
                (self._speed_item(dxl_id), "velocity_limit", "default/profile_vel", start.profile_vel)):
            if model.has(item) and not self.kept.sets(dxl_id, item):
                pulses = self._within(dxl_id, item, limit, param, value)
                written = self.io.write_item(dxl_id, item, pulses)
                if not written:  # e.g. above a P servo's velocity limit
                    self.log.warning(f"ID {dxl_id} ({model.name}): {param} = {value:g} not set "
                                     f"({item} {pulses} refused: {written.why})")
        self.watchdog.request_arm(dxl_id)

    def _speed_item(self, dxl_id: int) -> str:
        """Where default/profile_vel goes: Profile Velocity, or on a model whose Moving Speed 0
        means "as fast as the motor goes" (Protocol 1.0, XL-320) Moving Speed in Joint Mode (left
        at 0, the first goal would be reached at full speed)."""
        model = self.table.model(dxl_id)
        if model.has("profile_velocity") or not model.family.fastest_at_zero:
            return "profile_velocity"
        return model.family.speed_item(False) if self.io.mode(dxl_id) in POSITION_MODES else "profile_velocity"

    def _within(self, dxl_id: int, item: str, limit: str, param: str, value: float) -> int:
        """A default profile in pulses, within what this servo takes: its e-Manual range and, where
        the family bounds profiles by them (P, PRO, Y), its Velocity / Acceleration Limit (one line
        when it had to be lowered: the servo would refuse it)."""
        model = self.table.model(dxl_id)
        pulses = int(units.unit_to_pulse([model], item, [value])[0])
        hi = model.value_range(item)[1]
        if model.family.profile_max is None and model.has(limit):
            bound = self.io.read_item(dxl_id, limit)
            if bound is not None and bound > 0:
                hi = min(hi, bound)
        if pulses <= hi:
            return pulses
        shown = float(units.pulse_to_unit([model], item, [hi])[0])
        self.log.info(f"ID {dxl_id} ({model.name}): {param} = {value:g} is beyond what it takes ({limit} and its "
                      f"e-Manual range): {item} set to {shown:g}")
        return hi

    def want_handled(self, dxl_id: int, handled: bool) -> None:
        """add_id (True) or remove_id (False) from a command, applied once the queued operations of
        this loop have run: the last request for an ID in a loop wins, so a script that adds and
        removes a servo many times a loop costs at most one change a loop."""
        if self.membership is None:
            self.membership = {}
        self.membership.pop(dxl_id, None)
        self.membership[dxl_id] = handled

    def apply_membership(self) -> None:
        """The add_id / remove_id requests of this loop (a removal: the table lets the servo go,
        the parts that watch it forget it)."""
        wanted, self.membership = self.membership or {}, None
        for dxl_id, handled in wanted.items():
            if not handled:
                self.table.remove(dxl_id)
            elif dxl_id not in self.table:
                self.add_id(dxl_id)

    def add_id(self, dxl_id: int) -> bool:
        """Ping ``dxl_id`` and handle it if it answers with a model of a used series (in Protocol
        1.0 too where a Protocol 1.0 family is used)."""
        seen: Seen | None = None
        number = self.bus.execute(Ping(dxl_id)).value
        if number is not None:
            seen = (2, number)
        elif self.scanning.protocol1():
            seen = self.scanning.ping1([dxl_id]).get(dxl_id)
        if seen is None:
            self.limited(logging.WARNING, f"ID {dxl_id}: no answer to ping, not added", f"not added {dxl_id}")
            return False
        model = lookup(seen)
        if model is None:
            self.limited(logging.WARNING, f"ID {dxl_id}: unknown model number {seen[1]}, not added", f"not added {dxl_id}")
            return False
        if model.series not in self.settings.scan.used_series:
            self.limited(logging.WARNING, f"ID {dxl_id}: {model.name} is series {model.series}, not enabled in "
                         "init/used_servo_series", f"not added {dxl_id}")
            return False
        self.table.add(dxl_id, model)
        self.limited(logging.INFO, f"ID {dxl_id}: {model.name} added", f"added {dxl_id}")
        self.setup_servo(dxl_id)  # the same set-up as at start-up
        return True
