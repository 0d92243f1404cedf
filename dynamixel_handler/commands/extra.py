"""The writable fields of DynamixelExtra as a command (loop thread). Nested message fields arrive
flattened with a dot (``drive_mode.reverse_mode``); a bit-field register is read, the given bits
changed, and written back, so fields not given keep their value."""
from __future__ import annotations

import logging
from typing import Any, Iterable, Mapping, Protocol, Sequence

from .. import units
from ..control_table import Model, ServoFamily
from ..core.api import ServoAccess
from ..servo import error_state


class Checks(Protocol):
    """What the extra command needs of ``commands.Commander`` (its checks and warnings)."""

    h: ServoAccess
    log: logging.Logger | logging.LoggerAdapter[Any]

    def warn(self, msg: str) -> None: ...
    def known_ids(self, ids: Iterable[int], what: str, family: ServoFamily | None = None,
                  allow_all: bool = False) -> list[tuple[int, int]]: ...
    def finite(self, what: str, field: str, dxl_id: int, value: float) -> bool: ...
    def _value(self, dxl_id: int, item: str) -> int | None: ...

#: field -> (item, EEPROM write needs torque off)
_SCALAR = {
    "return_delay_time_us": "return_delay_time", "shadow_id": "secondary_id",
    "homing_offset_deg": "homing_offset", "moving_threshold_deg_s": "moving_threshold",
    "bus_watchdog_ms": "bus_watchdog",
}
_READ_ONLY = ("model", "model_number", "protocol_type", "firmware_version", "realtime_tick_s", "moving",
              "moving_status.velocity_profile", "moving_status.following_error", "moving_status.profile_ongoing",
              "moving_status.in_position")
#: PWM slope register range (X330 only; unit 3.955 mV/ms, published and taken as the register value)
PWM_SLOPE_RANGE = (1, 255)
_DRIVE = ("drive_mode.torque_on_by_goal_update", "drive_mode.profile_configuration", "drive_mode.reverse_mode")
_RESTORE = ("restore_configuration.ram_restore", "restore_configuration.startup_torque_on")


def apply_extra(c: Checks, ids: list[int], fields: Mapping[str, Sequence[Any]], what: str) -> None:
    for name in fields:
        if name in _READ_ONLY:
            c.warn(f"{what}: '{name}' is read-only: ignored")
    for k, dxl_id in c.known_ids(ids, what):
        _apply_one(c, dxl_id, _Given(fields, k, len(ids)), what)


def _apply_one(c: Checks, dxl_id: int, given: _Given, what: str) -> None:
    fields, k, model = given.fields, given.k, c.h.model(dxl_id)
    for field, item in _SCALAR.items():
        if field in fields and c.finite(what, field, dxl_id, fields[field][k]):
            _scalar(c, dxl_id, model, field, item, float(fields[field][k]), what)
    _bit_registers(c, dxl_id, model, given, what)
    if "pwm_slope_percent" in fields and c.finite(what, "pwm_slope_percent", dxl_id, fields["pwm_slope_percent"][k]):
        _pwm_slope(c, dxl_id, model, round(float(fields["pwm_slope_percent"][k])), what)
    for colour in ("red", "green", "blue"):
        field = f"led.{colour}_percent"
        if field in fields and c.finite(what, field, dxl_id, fields[field][k]):
            _led(c, dxl_id, model, colour, min(max(float(fields[field][k]), 0.0), 100.0), what)
    if "reboot" in fields and fields["reboot"][k]:
        _reboot(c, dxl_id)
    if "extra" in c.h.settings.logs.writes:
        c.log.info(f"{what}: ID {dxl_id} extra fields handled: {', '.join(sorted(fields))}")


def _reboot(c: Checks, dxl_id: int) -> None:
    """A reboot (refused within clear_error_interval_sec of the servo's last one), its torque read anew."""
    if c.h.core.reboot(dxl_id):
        c.h.read_item(dxl_id, "torque_enable")


def _bit_registers(c: Checks, dxl_id: int, model: Model, given: _Given, what: str) -> None:
    """Drive Mode, Startup Configuration, Shutdown: the bits given changed, the others kept."""
    fields = given.fields
    if any(f in fields for f in _DRIVE) and model.has("drive_mode"):
        _drive_mode(c, dxl_id, given, what)
    if any(f in fields for f in _RESTORE) and model.has("startup_configuration"):
        _restore_configuration(c, dxl_id, given)
    if any(f.startswith("shutdown.") for f in fields) and model.has("shutdown"):
        # in the X and P bit layout; the XL-320's own order (error_state.common_bits) on its register
        old = units.decode_shutdown([error_state.common_bits(model, c._value(dxl_id, "shutdown") or 0)])
        flags = {name: bool(given(f"shutdown.{name}", old[name][0])) for name in old}
        c.h.core.write_eeprom(dxl_id, "shutdown", error_state.own_bits(model, units.encode_shutdown(**flags)))


class _Given:
    """A field's value for the servo at index ``k`` of the command, or a default when not given."""

    def __init__(self, fields: Mapping[str, Sequence[Any]], k: int, n: int) -> None:
        self.fields, self.k, self.n = fields, k, n

    def __call__(self, name: str, default: object) -> object:
        values = self.fields.get(name)
        return default if values is None else values[self.k]


def _scalar(c: Checks, dxl_id: int, model: Model, field: str, item: str, value: float, what: str) -> None:
    if not model.has(item):
        c.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
        return
    if item == "bus_watchdog" and value < 0:
        c.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} refused (negative; 0 switches the watchdog off)")
        return
    pulses = _pulses(model, item, value)
    spec = model.item(item)
    if pulses is None or not spec.min_raw <= pulses <= spec.max_raw:
        c.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} is out of range: refused")
        return
    if item == "bus_watchdog":  # the servo keeps this one, whatever its mode (0: off)
        c.h.core.set_user_watchdog(dxl_id, pulses)
        return
    written = (c.h.core.write_eeprom(dxl_id, item, pulses) if spec.eeprom else c.h.core.write_item(dxl_id, item, pulses))
    if not written:
        c.warn(f"{what}: ID {dxl_id} writing {item} failed: {written.failure}")


def _pulses(model: Model, item: str, value: float) -> int | None:
    """``value`` in the register's units; None when it lies beyond what the register's bytes hold
    (the conversion would clip it: more than one register unit from what the pulses stand for)."""
    if item == "secondary_id":
        return int(value)
    pulses = int(units.unit_to_pulse([model], item, [value])[0])
    back, step = units.pulse_to_unit([model, model], item, [pulses, pulses + 1])
    if abs(float(back) - value) > abs(float(step) - float(back)):
        return None
    if item == "bus_watchdog" and value > 0:
        pulses = max(1, pulses)  # a time under one register unit is one unit, not off
    return pulses


def _drive_mode(c: Checks, dxl_id: int, given: _Given, what: str) -> None:
    """The drive mode bits given changed, the others kept."""
    current = c._value(dxl_id, "drive_mode") or 0
    old = units.decode_drive_mode([current])
    profile = given("drive_mode.profile_configuration", old["profile_configuration"][0])
    if profile not in ("time_based", "velocity_based"):
        c.warn(f"{what}: ID {dxl_id} unknown profile_configuration '{profile}': ignored")
        profile = old["profile_configuration"][0]
    value = units.encode_drive_mode(
        reverse_mode=bool(given("drive_mode.reverse_mode", old["reverse_mode"][0])),
        profile_configuration=str(profile),
        torque_on_by_goal_update=bool(given("drive_mode.torque_on_by_goal_update", old["torque_on_by_goal_update"][0])))
    c.h.core.write_eeprom(dxl_id, "drive_mode", value | (current & ~0x0D))


def _restore_configuration(c: Checks, dxl_id: int, given: _Given) -> None:
    ram, torque = units.decode_startup_configuration([c._value(dxl_id, "startup_configuration") or 0])
    value = units.encode_startup_configuration(ram_restore=bool(given(_RESTORE[0], ram[0])),
                                               startup_torque_on=bool(given(_RESTORE[1], torque[0])))
    c.h.core.write_eeprom(dxl_id, "startup_configuration", value)


def _pwm_slope(c: Checks, dxl_id: int, model: Model, slope: int, what: str) -> None:
    if not model.has("pwm_slope"):
        c.warn(f"{what}: ID {dxl_id} ({model.name}) has no pwm_slope (X330 only): ignored")
    elif not PWM_SLOPE_RANGE[0] <= slope <= PWM_SLOPE_RANGE[1]:
        c.warn(f"{what}: ID {dxl_id} 'pwm_slope_percent' = {slope} is out of range "
               f"{PWM_SLOPE_RANGE[0]}..{PWM_SLOPE_RANGE[1]}: refused")
    elif not (written := c.h.core.write_eeprom(dxl_id, "pwm_slope", slope)):
        c.warn(f"{what}: ID {dxl_id} writing pwm_slope failed: {written.failure}")


def _led(c: Checks, dxl_id: int, model: Model, colour: str, percent: float, what: str) -> None:
    if model.has(f"led_{colour}"):  # P, Pro: 0..255, rounded half up (50 % -> 128)
        c.h.core.write_item(dxl_id, f"led_{colour}", int(percent * 255.0 / 100.0 + 0.5))
    elif colour == "red" and model.has("led"):  # X: one LED, on from 50 %
        c.h.core.write_item(dxl_id, "led", 1 if percent >= 50.0 else 0)
    elif model.has("led_colour"):  # XL-320: one colour, a bit per LED (0 red, 1 green, 2 blue), on from 50 %
        bit = 1 << ("red", "green", "blue").index(colour)
        old = c._value(dxl_id, "led_colour") or 0
        c.h.core.write_item(dxl_id, "led_colour", old | bit if percent >= 50.0 else old & ~bit)
    else:
        c.warn(f"{what}: ID {dxl_id} ({model.name}) has no {colour} LED: ignored")
