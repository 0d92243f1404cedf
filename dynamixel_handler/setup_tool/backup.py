"""backup: each servo's model, ID, rate and EEPROM items in a YAML file a person can read and edit
(raw register values, the physical value beside each as a comment); ``restore`` (:mod:`.restore`)
writes it back, onto a replacement servo too. ``--servos-block FILE`` also writes the servos' mode,
gains, limits, profiles and once-set items as the handler's ``servos`` block (a parameters file)."""
from __future__ import annotations

import argparse
import datetime
from typing import Any, Callable, Iterable

from ..protocol.framers import FRAMERS
from ..servo.snapshot import entry_of, servos_yaml
from .context import Context
from .errors import StepFailed
from .items import to_unit, unit_of
from .output import Output
from .plot import check_writable
from .restore_file import present
from .servo import Servo
from .values import number, servo_doc

__all__ = ["backup", "check_paths", "save"]


def _firmware(servo: Servo) -> int | None:
    """Its firmware: from the ping where its protocol's ping carries it (Protocol 2.0), else its
    model's item (a Protocol 1.0 status has none, and the item's address depends on the model)."""
    if FRAMERS[servo.protocol].ping_identity and servo.dxl_id in servo.bus.firmware_versions:
        return servo.bus.firmware_versions[servo.dxl_id]
    return servo.read("firmware_version") if servo.model.has("firmware_version") else None


def _servo_yaml(servo: Servo) -> list[str]:
    firmware = _firmware(servo)
    model = servo.model
    lines = [f"  {servo.dxl_id}:", f"    model: {model.name}", f"    model_number: {model.number}",
             f"    baudrate: {servo.bus.baudrate}", f"    protocol: {servo.protocol}"]
    if firmware is not None:
        lines.append(f"    firmware: {firmware}")
    lines.append("    eeprom:")
    for name, raw in present(servo).items():
        item = model.item(name)
        value = to_unit(model, item, raw)
        note = f"  # {number(value, 6)} {unit_of(model, item)}" if value is not None else ""
        lines.append(f"      {item.name}: {raw}{note}")
    return lines


def _reader(servo: Servo) -> Callable[[str], int | None]:
    """Reads an item of ``servo``; None where the read fails (the item is left out of the block)."""
    def read(name: str) -> int | None:
        try:
            return servo.read(name)
        except StepFailed:
            return None
    return read


def _write(path: str, text: str) -> None:
    try:
        with open(path, "w", encoding="utf-8") as handle:
            handle.write(text)
    except OSError as exc:
        raise StepFailed(f"cannot write {path}: {exc.strerror}") from None


def check_paths(args: argparse.Namespace) -> None:
    """The files a backup writes can be written (said at once, before any servo is looked for)."""
    check_writable(args.file, "backup")
    if getattr(args, "servos_block", None):
        check_writable(args.servos_block, "backup --servos-block")


def save(out: Output, args: argparse.Namespace, servos: Iterable[Servo], device: str) -> list[int]:
    """The backup of ``servos`` (each read as it comes) written to ``args.file`` (and the servos
    block); the IDs saved."""
    lines = ["# dynamixel_handler_setup backup: each servo by its ID, with its model, baud rate and EEPROM items",
             "# (raw register values; the physical value in the comment). Edit a value to change it: restore",
             "# checks every value first, writes only what differs and reads it back; a servo not found at its",
             "# ID is restored onto the one unassigned servo of its model (a replacement), ID and rate first.",
             f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
             "servos:"]
    saved = []
    entries: list[tuple[int, dict[str, Any]]] = []
    for servo in servos:
        lines += _servo_yaml(servo)
        saved.append(servo.dxl_id)
        if getattr(args, "servos_block", None):
            entries.append((servo.dxl_id, entry_of(servo.model, _reader(servo), servo.mode())))
    _write(args.file, "\n".join(lines) + "\n")
    out.say(f"{len(saved)} servo(s) saved to {args.file}: IDs {', '.join(map(str, saved))}")
    if getattr(args, "servos_block", None):
        _write(args.servos_block, servos_yaml(entries, device))
        out.say(f"the servos block of IDs {', '.join(map(str, saved))} written to {args.servos_block} "
                "(a parameters file for the handler)")
    out.document.update(file=args.file, ids=saved)
    return saved


def backup(ctx: Context, args: argparse.Namespace) -> None:
    check_paths(args)  # before the search: a path that cannot be written is said at once
    found = ctx.servos(args.ids)
    save(ctx.out, args, (ctx.at(p) for p in found.placed), ctx.bus.device)
    ctx.out.document.update(missing=found.missing,
                            servos=[servo_doc(p.dxl_id, p.servo.model, p.baudrate) for p in found.placed])
    ctx.fail_if_missing(found, f"the others were saved to {args.file}")
