"""The verbs that read and set one servo: info, get, set, set-id, set-baud, set-mode.

Values are by item name and in physical units, range checked against the model's control table
before anything is sent; EEPROM items are written with torque off and torque restored (a Protocol
1.0 model takes them with torque on: only its Angle Limits, which switch its mode, need torque
off), read back and verified, and only when they differ (EEPROM wear). ``set ID protocol_type``
switches an X or MX(2.0) servo between Protocol 2.0 and 1.0 and finds it in the other one."""
from __future__ import annotations

import argparse
from typing import Any

from ..bus import DYNAMIXEL_BAUDRATES, BusError
from ..bus.ops import Ping
from ..control_table import Item, Model
from ..units import decode
from . import guard
from .context import Context
from .errors import BadArguments, StepFailed
from .items import parse_value, show_value, to_unit, unit_of
from .mode1 import set_mode1, state_line, summary
from .output import Output
from .per_protocol import rates_text, tool_protocol
from .protocol1 import protocol_of_type
from .safety import held
from .servo import Servo, connect
from .values import named, number

__all__ = ["info", "info_items", "show_info", "get", "set_item", "set_id", "set_baud", "set_mode"]

#: items `info` leaves out unless --all (hundreds of indirect entries)
_BULKY = ("indirect_address_", "indirect_data_")
#: bytes per read of `info`
_CHUNK = 64


def _read_all(servo: Servo, items: list[Item]) -> dict[str, int]:
    """Every item's raw value, read in runs of neighbouring items (up to ``_CHUNK`` bytes each)."""
    values: dict[str, int] = {}
    runs: list[list[Item]] = []
    for item in sorted(items, key=lambda i: i.address):
        if runs and item.address + item.size - runs[-1][0].address <= _CHUNK:
            runs[-1].append(item)
        else:
            runs.append([item])
    for run in runs:
        data = servo.read_block(run[0], run[-1])
        for it in run:
            values[it.name] = int(decode(it, data[it.address - run[0].address:])[0])
    return values


def info(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.id)
    guard.only_one(ctx, servo)
    items = info_items(servo.model, args.all)
    show_info(ctx.out, servo, ctx.bus.baudrate, items, _read_all(servo, items))


def info_items(model: Model, everything: bool) -> list[Item]:
    """The items ``info`` shows (the indirect entries only with ``--all``)."""
    return [i for i in model.items.values() if everything or not i.name.startswith(_BULKY)]


def show_info(out: Output, servo: Servo, baudrate: int, items: list[Item], values: dict[str, int]) -> None:
    """The state line and the EEPROM and RAM tables of ``values`` (item -> raw) of ``servo``."""
    model = servo.model
    rows: dict[bool, list[list[object]]] = {True: [], False: []}
    styles: dict[bool, list[str | None]] = {True: [], False: []}
    doc: dict[str, Any] = {}
    for item in sorted(items, key=lambda i: i.address):
        raw = values[item.name]
        factory = model.factory.get(item.name)
        differs = factory is not None and factory != raw
        value = to_unit(model, item, raw)
        rows[item.eeprom].append([item.address, item.name, number(value) if value is not None else named(model, item, raw),
                                  unit_of(model, item), raw, "" if factory is None else factory,
                                  "*" if differs else ""])
        styles[item.eeprom].append("yellow" if differs else None)
        doc[item.name] = {"raw": raw, "value": value, "unit": unit_of(model, item), "text": show_value(model, item, raw),
                          "eeprom": item.eeprom,
                          "address": item.address, "factory": factory, "differs_from_factory": differs}
    head = f"ID {servo.dxl_id}: {model.name} (model {model.number}) at {baudrate} bps"
    out.say(head)
    state = summary(servo, values)
    out.say(state_line(state))
    columns = ["addr", "item", "value", "unit", "raw", "factory", "differs"]
    out.table(tool_protocol(model.protocol).eeprom_caption, columns, rows[True], styles[True])
    out.table("RAM", columns, rows[False], styles[False])
    out.say("* differs from the factory value of the model (ROBOTIS e-Manual)")
    out.document.update(id=servo.dxl_id, model=model.name, model_number=model.number,
                        baudrate=baudrate, **state, items=doc)


def get(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.id)
    guard.only_one(ctx, servo)  # which of two servos at one ID would be read cannot be told
    item = servo.item(args.item)
    raw = servo.read(item.name)
    ctx.out.say(f"{servo.who} {item.name} = {show_value(servo.model, item, raw)}")
    ctx.out.document.update(id=servo.dxl_id, item=item.name, raw=raw, value=to_unit(servo.model, item, raw),
                            unit=unit_of(servo.model, item), text=show_value(servo.model, item, raw))


def _apply(ctx: Context, servo: Servo, item: Item, raw: int) -> None:
    """Confirm (EEPROM), write when it differs, verify, report."""
    before = servo.read(item.name)
    shown = show_value(servo.model, item, raw)
    doc = {"id": servo.dxl_id, "item": item.name, "raw": raw, "before": before}
    if before == raw:
        ctx.out.say(f"{servo.who} {item.name} is already {shown}: nothing written")
        ctx.out.document.update(doc, written=False)
        return
    torque = guard.torque_gate(ctx, servo, [item])
    if item.eeprom:
        ctx.confirm(f"{servo.who}: write {item.name} (EEPROM) from {show_value(servo.model, item, before)} to {shown}?"
                    + guard.torque_question(torque))
    if item.name == "torque_enable" and raw == 1:
        with held():  # as the handler does: the goal where the servo is, no jump
            servo.torque_on_in_place()
        if servo.read(item.name) != 1:
            raise StepFailed(f"{servo.who}: torque_enable reads 0 after torque on")
    else:
        servo.set_checked(item.name, raw, torque_off=ctx.torque_off)
    ctx.out.say(f"{servo.who} {item.name} = {shown} (was {show_value(servo.model, item, before)}), read back"
                + guard.torque_done(torque))
    ctx.out.document.update(doc, written=True)


def set_item(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.id)
    item = servo.item(args.item)
    if item.name in ("id", "baud_rate"):
        raise BadArguments(f"{servo.who}: use set-{'id' if item.name == 'id' else 'baud'} for {item.name} "
                           "(it checks the new address and finds the servo there)")
    raw = parse_value(servo.model, item, args.value, servo.who, raw=ctx.raw)
    guard.check_values(ctx, servo, {item.name: raw})
    guard.only_one(ctx, servo)
    if item.name == "protocol_type":
        _switch_protocol(ctx, servo, item, raw)
        return
    _apply(ctx, servo, item, raw)


def _switch_protocol(ctx: Context, servo: Servo, item: Item, raw: int) -> None:
    """Protocol Type written (EEPROM), and the servo found again in the protocol it now answers."""
    new = protocol_of_type(raw)
    ctx.out.document.update(protocol=servo.protocol)
    if servo.read(item.name) == raw:
        ctx.out.say(f"{servo.who} protocol_type is already {raw}: nothing written")
        ctx.out.document.update(item=item.name, raw=raw, written=False)
        return
    switch_warning = tool_protocol(new).switch_warning
    if switch_warning is not None:
        ctx.out.warn(switch_warning(servo.who, servo.dxl_id))
    torque = guard.torque_gate(ctx, servo, [item])
    ctx.confirm(f"{servo.who}: write protocol_type (EEPROM) {servo.read(item.name)} -> {raw}: it then answers "
                f"Protocol {new}.0 only?" + guard.torque_question(torque))
    servo.set_checked(item.name, raw, after=lambda: connect(ctx.bus, servo.dxl_id, new), torque_off=ctx.torque_off)
    ctx.out.say(f"{servo.who} protocol_type = {raw}: it answers Protocol {new}.0 now (found again and read back "
                f"in Protocol {new}.0)" + guard.torque_done(torque))
    ctx.out.document.update(item=item.name, raw=raw, written=True, protocol=new)


def set_mode(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.id)
    if servo.modes_by_limits:
        guard.only_one(ctx, servo)
        set_mode1(ctx, servo, str(args.mode))
        return
    text = str(args.mode).strip().lower()
    modes = servo.model.mode_values
    raw = modes.get(text)
    if raw is None:
        try:
            raw = int(text)
        except ValueError:
            raise BadArguments(f"{servo.who}: {servo.model.name} has no operating mode '{args.mode}' "
                               f"(one of {', '.join(modes)} or a register value)") from None
    item = servo.item("operating_mode")
    guard.only_one(ctx, servo)
    _apply(ctx, servo, item, parse_value(servo.model, item, str(raw), servo.who, raw=True))


def set_id(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.old)
    item = servo.item("id")
    new = parse_value(servo.model, item, str(args.new), servo.who)
    if new == servo.dxl_id:
        ctx.out.say(f"{servo.who} already has ID {new}: nothing written")
        ctx.out.document.update(id=new, written=False)
        return
    taken = ctx.bus.execute(Ping(new, retries=1, protocol=servo.protocol)).value
    if taken is not None:
        raise StepFailed(f"{servo.who}: ID {new} is already in use at {ctx.bus.baudrate} bps (model {taken}): "
                         "two servos at one ID cannot be told apart; choose another")
    guard.only_one(ctx, servo)
    torque = guard.torque_gate(ctx, servo, [item])
    ctx.confirm(f"{servo.who}: change its ID to {new} (EEPROM)?" + guard.torque_question(torque))
    servo.set_checked("id", new, after=lambda: connect(ctx.bus, new, servo.protocol), torque_off=ctx.torque_off)
    ctx.out.say(f"ID {servo.dxl_id} -> {new} ({servo.model.name}): answers at ID {new}, read back"
                + guard.torque_done(torque))
    ctx.out.document.update(old=servo.dxl_id, id=new, written=True)


def set_baud(ctx: Context, args: argparse.Namespace) -> None:
    servo = ctx.servo(args.id)
    by_bps = {bps: value for value, bps in servo.model.baud_rates.items()}
    if args.bps not in by_bps:
        takes = tool_protocol(servo.model.protocol).baud_text(by_bps)
        raise BadArguments(f"{servo.who} cannot use {args.bps} bps (it takes {takes})")
    if args.bps not in DYNAMIXEL_BAUDRATES:
        raise BadArguments(f"{servo.who}: {args.bps} bps (Baud Rate {by_bps[args.bps]}) is in its table but this tool's "
                           f"bus cannot open that rate, so it could not find the servo there: not written (rates both "
                           f"can use: {rates_text([b for b in by_bps if b in DYNAMIXEL_BAUDRATES])})")
    old = ctx.bus.baudrate
    if old == args.bps:
        ctx.out.say(f"{servo.who} is already at {old} bps: nothing written")
        ctx.out.document.update(id=servo.dxl_id, baudrate=old, written=False)
        return
    ctx.bus.set_baudrate(args.bps)
    there = ctx.bus.execute(Ping(servo.dxl_id, retries=1, protocol=servo.protocol)).value
    ctx.bus.set_baudrate(old)
    if there is not None:
        raise StepFailed(f"{servo.who}: another servo (model {there}) answers at ID {servo.dxl_id} at {args.bps} bps: "
                         "the two would collide there; give one another ID first")
    guard.only_one(ctx, servo)
    torque = guard.torque_gate(ctx, servo, [servo.item("baud_rate")])
    ctx.confirm(f"{servo.who}: change its baud rate from {old} to {args.bps} bps (EEPROM)?" + guard.torque_question(torque))

    def found_again() -> Servo:
        try:
            ctx.bus.set_baudrate(args.bps)
        except BusError as exc:
            raise StepFailed(f"{servo.who} was set to {args.bps} bps but the adapter cannot use it: {exc}") from None
        try:
            return connect(ctx.bus, servo.dxl_id, servo.protocol)
        except StepFailed as exc:
            raise StepFailed(f"{exc}: its Baud Rate was written; it is at {args.bps} bps or still at {old}") from None

    servo.set_checked("baud_rate", by_bps[args.bps], after=found_again, torque_off=ctx.torque_off)
    ctx.out.say(f"{servo.who}: {old} -> {args.bps} bps, found again at {args.bps} bps" + guard.torque_done(torque))
    ctx.out.document.update(id=servo.dxl_id, baudrate=args.bps, was=old, written=True)
