"""The set-up every servo gets, at start-up, when added later (add_id) and after a reconnect: a
hardware error cleared, the servos block applied, return delay and profile defaults, torque as
the parameters say; the bus watchdog armed when the loop next runs."""
from __future__ import annotations

from dataclasses import dataclass

from .. import units
from ..control_table import KEPT_POSITION_MODES, POSITION_MODES
from ..control_table.behaviour import ByClearInstruction
from ..servo import error_state
from ..servo.table import ServoTable
from ..settings import ScanSettings, StartValues
from .deferred import Deferred
from .kept_settings import KeptSettings
from .reboots import Reboots
from .servo_io import Log, ServoIO
from .turns import give_back_turns
from .watchdog import Watchdog


@dataclass(frozen=True)
class SetupSettings:
    hardware_error_auto_clean: bool = True  # init/hardware_error_auto_clean
    torque_auto_enable: bool = True         # init/torque_auto_enable
    start: StartValues = StartValues()      # the values every servo gets

    @staticmethod
    def of(scan: ScanSettings, start: StartValues) -> SetupSettings:
        return SetupSettings(scan.hardware_error_auto_clean, scan.torque_auto_enable, start)


class ServoSetup:
    """One servo set up as the parameters say (``setup_servo``); ``kept`` is the servos block."""

    def __init__(self, table: ServoTable, log: Log, io: ServoIO, eeprom: Deferred, watchdog: Watchdog,
                 kept: KeptSettings, reboots: Reboots, settings: SetupSettings) -> None:
        self.table, self.log, self.io, self.eeprom, self.watchdog = table, log, io, eeprom, watchdog
        self.kept = kept
        self.reboots = reboots
        self.settings = settings

    def setup_servo(self, dxl_id: int, torque: bool | None = None) -> None:
        """The set-up every servo gets, at start-up and when added later (add_id): hardware error
        cleared (init/hardware_error_auto_clean), the servos block's EEPROM items and mode, return
        delay, profile defaults, the block's RAM items, torque as init/torque_auto_enable says; the
        bus watchdog when the loop next runs. The block's items replace the defaults. ``torque``:
        on or left off whatever the parameter says (a servo set up again keeps what it had)."""
        settings, model = self.settings, self.table.model(dxl_id)
        if settings.hardware_error_auto_clean:
            self._clear_error(dxl_id)
        done = self.kept.prepare(dxl_id)
        if not self.kept.sets(dxl_id, "return_delay_time"):
            delay = int(units.unit_to_pulse([model], "return_delay_time", [settings.start.return_delay_time])[0])
            self.eeprom.write_eeprom(dxl_id, "return_delay_time", delay)
        self._setup_ram(dxl_id)
        self.kept.finish(dxl_id, done)
        if settings.torque_auto_enable if torque is None else torque:
            self.io.torque_on(dxl_id)

    def give_back_turns(self, dxl_id: int, before: int) -> None:
        """A multi-turn servo that lost power: the whole turns it lost since it was at ``before``
        [pulses] given back (``turns.py``), unless its servos block sets the Homing Offset."""
        if self.io.mode(dxl_id) not in KEPT_POSITION_MODES:
            return
        if self.kept.sets(dxl_id, "homing_offset"):
            self.log.info(f"ID {dxl_id}: whole turns lost at boot not looked for: its servos block sets homing_offset")
            return
        line = give_back_turns(self.io, self.eeprom, dxl_id, before, booted=False)
        if line:
            self.log.warning(line)

    def _clear_error(self, dxl_id: int) -> None:
        """A hardware error at start-up cleared by its family's clear instruction where it has one (Y),
        else by a reboot (which also gives a Protocol 1.0 servo the Torque Limit its shutdown cut)."""
        model = self.table.model(dxl_id)
        err = self.io.read_item(dxl_id, error_state.error_item(model))
        if not error_state.is_error(model, err):
            return
        clearing = model.family.behaviour.clearing
        if isinstance(clearing, ByClearInstruction):
            self.log.warning(f"ID {dxl_id}: {error_state.describe(model, err or 0)} at start-up: clearing it")
            cleared = self.reboots.clear_error(dxl_id, params=clearing.params)
            if not cleared:
                self.log.warning(f"ID {dxl_id}: error not cleared: {cleared.why}")
            return
        self.log.warning(f"ID {dxl_id}: hardware error 0x{err or 0:02X} at start-up: clearing it by reboot")
        self.reboots.reboot(dxl_id)

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
        behaviour = model.family.behaviour
        if not behaviour.speed_in_position_only(model):
            return "profile_velocity"
        return behaviour.speed_item(model) if self.io.mode(dxl_id) in POSITION_MODES else "profile_velocity"

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
