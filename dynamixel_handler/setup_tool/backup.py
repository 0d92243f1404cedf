"""backup / restore: each servo's model and EEPROM items in a YAML file a person can read and edit
(raw register values, the physical value beside each as a comment). Restore checks every servo's
model before anything is written, shows what it will change, writes only what differs (EEPROM
wear) with torque off and torque restored, and reads every value back."""
from __future__ import annotations

import argparse
import datetime
from typing import Any

import yaml

from ..bus import DYNAMIXEL_BAUDRATES
from ..control_table import Item, model_by_number
from .context import Context
from .errors import BadArguments, StepFailed
from .items import check_raw, show_value, to_unit, unit_of
from .servo import Servo
from .values import number, servo_doc

__all__ = ["backup", "restore"]

#: EEPROM items that say what the servo is, never written back (the model is checked instead)
_IDENTITY = ("model_number", "model_information", "firmware_version")
#: written after the others (a servo would leave the bus's rate / address)
_LAST = ("id", "baud_rate")


def _kept(item: Item) -> bool:
    return item.eeprom and item.name not in _IDENTITY and not item.name.startswith("indirect_")


def _servo_yaml(servo: Servo, firmware: int | None) -> list[str]:
    model = servo.model
    lines = [f"  {servo.dxl_id}:", f"    model: {model.name}", f"    model_number: {model.number}",
             f"    baudrate: {servo.bus.baudrate}"]
    if firmware is not None:
        lines.append(f"    firmware: {firmware}")
    lines.append("    eeprom:")
    for item in sorted(model.items.values(), key=lambda i: i.address):
        if _kept(item):
            raw = servo.read(item.name)
            value = to_unit(model, item, raw)
            note = f"  # {number(value, 6)} {unit_of(model, item)}" if value is not None else ""
            lines.append(f"      {item.name}: {raw}{note}")
    return lines


def backup(ctx: Context, args: argparse.Namespace) -> None:
    lines = ["# dynamixel_handler_setup backup: each servo's model and EEPROM items (raw register values;",
             "# the physical value in the comment). Edit a value to change it: restore checks the model,",
             "# writes only what differs and reads it back.",
             f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
             "servos:"]
    saved = []
    found = ctx.servos(args.ids)
    for placed in found.placed:
        servo = ctx.at(placed)
        lines += _servo_yaml(servo, ctx.bus.firmware_versions.get(servo.dxl_id))
        saved.append(servo.dxl_id)
    try:
        with open(args.file, "w", encoding="utf-8") as handle:
            handle.write("\n".join(lines) + "\n")
    except OSError as exc:
        raise StepFailed(f"cannot write {args.file}: {exc.strerror}") from None
    ctx.out.say(f"{len(saved)} servo(s) saved to {args.file}: IDs {', '.join(map(str, saved))}")
    ctx.out.document.update(file=args.file, ids=saved, missing=found.missing,
                            servos=[servo_doc(p.dxl_id, p.servo.model, p.baudrate) for p in found.placed])
    ctx.fail_if_missing(found, f"the others were saved to {args.file}")


def _load(path: str) -> dict[int, dict[str, Any]]:
    try:
        with open(path, encoding="utf-8") as handle:
            data = yaml.safe_load(handle)
    except OSError as exc:
        raise BadArguments(f"cannot read {path}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise BadArguments(f"{path} is not YAML: {str(exc).splitlines()[0]}") from None
    servos = data.get("servos") if isinstance(data, dict) else None
    if not isinstance(servos, dict) or not all(isinstance(k, int) and isinstance(v, dict) for k, v in servos.items()):
        raise BadArguments(f"{path} is not a backup of this tool (no 'servos:' map of IDs)")
    return servos


Plan = tuple[Servo, int, list[tuple[Item, int, int]]]


def _plan(ctx: Context, dxl_id: int, entry: dict[str, Any], path: str) -> Plan:
    """The servo, its baud rate and its (item, now, from the file) that differ; BadArguments on a
    model mismatch. Without --baud the servo is looked for at the file's rate first, then everywhere."""
    if not ctx.baud_given and entry.get("baudrate") in DYNAMIXEL_BAUDRATES:
        ctx.bus.set_baudrate(int(entry["baudrate"]))
    servo = ctx.servo(dxl_id)
    number = entry.get("model_number")
    if number != servo.model.number:
        try:
            named = model_by_number(int(str(number))).name
        except (KeyError, TypeError, ValueError):
            named = f"model {number}"
        raise BadArguments(f"{servo.who}: {path} holds a {named} for ID {dxl_id}: refused, nothing written")
    values = entry.get("eeprom")
    if not isinstance(values, dict):
        raise BadArguments(f"{path}: ID {dxl_id} has no 'eeprom:' map")
    changes = []
    for name, raw in values.items():
        item = servo.model.items.get(str(name))
        if item is None or not _kept(item) or not isinstance(raw, int):
            raise BadArguments(f"{path}: ID {dxl_id} {name}: {raw!r} is not a raw value of an EEPROM item of "
                               f"{servo.model.name}")
        check_raw(servo.model, item, raw, f"{path}: {servo.who}")
        now = servo.read(item.name)
        if now != raw:
            changes.append((item, now, raw))
    changes.sort(key=lambda c: (c[0].name in _LAST, c[0].address))
    return servo, ctx.bus.baudrate, changes


def restore(ctx: Context, args: argparse.Namespace) -> None:
    entries = _load(args.file)
    plans = [_plan(ctx, dxl_id, entry, args.file) for dxl_id, entry in sorted(entries.items())]
    changed = [(s, item, now, raw) for s, _bps, changes in plans for item, now, raw in changes]
    rows = [[s.dxl_id, item.name, show_value(s.model, item, now), show_value(s.model, item, raw)]
            for s, item, now, raw in changed]
    ctx.out.table(f"restore from {args.file}", ["ID", "item", "now", "from the file"], rows)
    ctx.out.document.update(file=args.file, dry_run=bool(args.dry_run),
                            changes=[{"id": s.dxl_id, "item": item.name, "now": now, "file": raw}
                                     for s, item, now, raw in changed])
    if not rows:
        ctx.out.say(f"every servo already matches {args.file}: nothing written")
        return
    if args.dry_run:
        ctx.out.say(f"dry run: {len(rows)} item(s) would be written, nothing written")
        return
    ctx.confirm(f"write these {len(rows)} EEPROM item(s)?")
    for servo, bps, changes in plans:
        ctx.bus.set_baudrate(bps)
        for item, _now, raw in changes:
            if item.name in _LAST:
                raise StepFailed(f"{servo.who}: {item.name} differs from {args.file} ({raw}); change it with "
                                 f"set-{'id' if item.name == 'id' else 'baud'} (the other items were restored)")
            servo.set_checked(item.name, raw)
    ctx.out.say(f"{len(rows)} item(s) written and read back")
