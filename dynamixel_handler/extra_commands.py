"""The writable fields of DynamixelExtra as a command (loop thread). Nested message fields arrive
flattened with a dot (``drive_mode.reverse_mode``); a bit-field register is read, the given bits
changed, and written back, so fields not given keep their value."""
from __future__ import annotations

import logging
from typing import Iterable, Mapping, Protocol, Sequence

from . import units
from .loop import Handler


class Checks(Protocol):
    """What the extra command needs of ``commands.Commander`` (its checks and warnings)."""

    h: Handler
    log: logging.Logger | logging.LoggerAdapter

    def warn(self, msg: str) -> None: ...
    def known_ids(self, ids: Iterable[int], what: str, series: str | None = None,
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


def apply_extra(c: Checks, ids: list[int], fields: Mapping[str, Sequence], what: str) -> None:
    for name in fields:
        if name in _READ_ONLY:
            c.warn(f"{what}: '{name}' is read-only: ignored")
    for k, dxl_id in c.known_ids(ids, what):
        h, model = c.h, c.h.table.model(dxl_id)
        for field, item in _SCALAR.items():
            if field not in fields or not c.finite(what, field, dxl_id, fields[field][k]):
                continue
            if not model.has(item):
                c.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
                continue
            value = float(fields[field][k])
            pulses = int(units.unit_to_pulse([model], item, [value])[0]) if item != "secondary_id" else int(value)
            spec = model.item(item)
            if not spec.min_raw <= pulses <= spec.max_raw:
                c.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} is out of range: refused")
                continue
            if item == "bus_watchdog":  # the servo keeps this one, whatever its mode (0: off)
                h.watchdog_user[dxl_id] = pulses
                h.arm_watchdog(dxl_id)
                continue
            ok = h.write_eeprom(dxl_id, item, pulses) if spec.eeprom else h.write_item(dxl_id, item, pulses)
            if not ok:
                c.warn(f"{what}: ID {dxl_id} writing {item} failed: {h.bus.last_failure}")
        if any(f in fields for f in _DRIVE) and model.has("drive_mode"):
            current = c._value(dxl_id, "drive_mode") or 0
            old = units.decode_drive_mode([current])
            profile = fields.get("drive_mode.profile_configuration", [old["profile_configuration"][0]] * len(ids))[k]
            if profile not in ("time_based", "velocity_based"):
                c.warn(f"{what}: ID {dxl_id} unknown profile_configuration '{profile}': ignored")
                profile = old["profile_configuration"][0]
            value = units.encode_drive_mode(
                reverse_mode=bool(fields.get("drive_mode.reverse_mode", [old["reverse_mode"][0]] * len(ids))[k]),
                profile_configuration=profile,
                torque_on_by_goal_update=bool(fields.get("drive_mode.torque_on_by_goal_update",
                                                         [old["torque_on_by_goal_update"][0]] * len(ids))[k]))
            h.write_eeprom(dxl_id, "drive_mode", value | (current & ~0x0D))
        if any(f in fields for f in _RESTORE) and model.has("startup_configuration"):
            ram, torque = units.decode_startup_configuration([c._value(dxl_id, "startup_configuration") or 0])
            value = units.encode_startup_configuration(
                ram_restore=bool(fields.get(_RESTORE[0], [ram[0]] * len(ids))[k]),
                startup_torque_on=bool(fields.get(_RESTORE[1], [torque[0]] * len(ids))[k]))
            h.write_eeprom(dxl_id, "startup_configuration", value)
        shutdown_fields = {f.split(".", 1)[1]: v for f, v in fields.items() if f.startswith("shutdown.")}
        if shutdown_fields and model.has("shutdown"):
            old = units.decode_shutdown([c._value(dxl_id, "shutdown") or 0])
            flags = {name: bool(shutdown_fields.get(name, [old[name][0]] * len(ids))[k]) for name in old}
            h.write_eeprom(dxl_id, "shutdown", units.encode_shutdown(**flags))
        if "pwm_slope_percent" in fields and c.finite(what, "pwm_slope_percent", dxl_id, fields["pwm_slope_percent"][k]):
            slope = round(float(fields["pwm_slope_percent"][k]))
            if not model.has("pwm_slope"):
                c.warn(f"{what}: ID {dxl_id} ({model.name}) has no pwm_slope (X330 only): ignored")
            elif not PWM_SLOPE_RANGE[0] <= slope <= PWM_SLOPE_RANGE[1]:
                c.warn(f"{what}: ID {dxl_id} 'pwm_slope_percent' = {slope} is out of range "
                       f"{PWM_SLOPE_RANGE[0]}..{PWM_SLOPE_RANGE[1]}: refused")
            elif not h.write_eeprom(dxl_id, "pwm_slope", slope):
                c.warn(f"{what}: ID {dxl_id} writing pwm_slope failed: {h.bus.last_failure}")
        for colour in ("red", "green", "blue"):
            field = f"led.{colour}_percent"
            if field not in fields or not c.finite(what, field, dxl_id, fields[field][k]):
                continue
            percent = min(max(float(fields[field][k]), 0.0), 100.0)
            if model.has(f"led_{colour}"):  # P, Pro: 0..255, rounded half up (50 % -> 128)
                h.write_item(dxl_id, f"led_{colour}", int(percent * 255.0 / 100.0 + 0.5))
            elif colour == "red" and model.has("led"):  # X: one LED, on from 50 %
                h.write_item(dxl_id, "led", 1 if percent >= 50.0 else 0)
            else:
                c.warn(f"{what}: ID {dxl_id} ({model.name}) has no {colour} LED: ignored")
        if "reboot" in fields and fields["reboot"][k]:
            h.reboot(dxl_id)
            h.read_item(dxl_id, "torque_enable")
        if h.config["verbose/write_extra"]:
            c.log.info(f"{what}: ID {dxl_id} extra fields handled: {', '.join(sorted(fields))}")
