"""``get``, ``set`` and ``set-mode`` on several servos at once (``set 1,2,5 profile_velocity 30rpm``):
every value parsed and checked for every servo first, then one Sync Read of the item for the servos
that share its address and rate, one Sync Write of those whose value differs (torque off before
and back on after, in one critical step, only with ``--torque-off``), one Sync Read to read them
back, and each servo's result reported. A servo that answers nowhere is named, the others done."""
from __future__ import annotations

import argparse
import time
from typing import Any, Callable, Iterable

from ..bus.ops import Read, SyncRead
from ..control_table import Item
from ..protocol.framers import FRAMERS
from ..units import decode, encode
from . import guard
from .context import Context
from .errors import BadArguments, StepFailed
from .find import Found, Placed
from .items import parse_value, show_value, to_unit, unit_of
from .mode1 import set_mode1
from .safety import JOURNAL, held
from .values import servo_doc

__all__ = ["get_many", "set_many", "mode_many", "one_or_many"]

#: (servo, item, raw value): one servo's part of a write
Want = tuple[Placed, Item, int]


def one_or_many(single: Callable[[Context, argparse.Namespace], None],
                many: Callable[[Context, argparse.Namespace], None]) -> Callable[[Context, argparse.Namespace], None]:
    """The verb for ``args.id`` (a list of IDs): the one-servo verb for one ID, else the many one."""
    def verb(ctx: Context, args: argparse.Namespace) -> None:
        if len(args.id) == 1:
            args.id = args.id[0]
            single(ctx, args)
        else:
            many(ctx, args)
    return verb


def _groups(placed: Iterable[Placed], item_of: Callable[[Placed], Item]) -> dict[tuple[int, int, int, int], list[Placed]]:
    """The servos by (rate, address, size, protocol) of their item: each group is one sync instruction."""
    groups: dict[tuple[int, int, int, int], list[Placed]] = {}
    for p in placed:
        item = item_of(p)
        groups.setdefault((p.baudrate, item.address, item.size, p.servo.protocol), []).append(p)
    return groups


def _read(ctx: Context, placed: list[Placed], item_of: Callable[[Placed], Item]) -> dict[int, int]:
    """ID -> raw value of its item, one sync read per group where its protocol has Sync Read (Protocol
    1.0 has none: a read per servo there); a silent servo is left out."""
    values: dict[int, int] = {}
    for (bps, address, size, protocol), group in _groups(placed, item_of).items():
        ctx.at(group[0])
        if FRAMERS[protocol].sync_read:
            got = ctx.bus.execute(SyncRead(address, size, tuple(p.dxl_id for p in group), protocol=protocol)).value
        else:
            got = {p.dxl_id: bytes(r.value) for p in group
                   if (r := ctx.bus.execute(Read(p.dxl_id, address, size, protocol=protocol))).value is not None}
        for p in group:
            if p.dxl_id in got:
                values[p.dxl_id] = int(decode(item_of(p), got[p.dxl_id])[0])
    return values


def _one_each(ctx: Context, placed: list[Placed]) -> None:
    """Without --baud: StepFailed naming both rates when an ID of the list answers at two (two servos
    have it, and which one is meant cannot be told); nothing is read or written then."""
    for p in placed:
        ctx.bus.set_baudrate(p.baudrate)
        guard.only_one(ctx, p.servo)


def get_many(ctx: Context, args: argparse.Namespace) -> None:
    found = ctx.servos(args.id)
    _one_each(ctx, found.placed)
    items = {p.dxl_id: p.servo.item(args.item) for p in found.placed}
    values = _read(ctx, found.placed, lambda p: items[p.dxl_id])
    docs, silent = [], []
    for p in found.placed:
        item, raw = items[p.dxl_id], values.get(p.dxl_id)
        if raw is None:
            silent.append(p.dxl_id)
            ctx.out.error(f"{p.servo.who}: no reply to the sync read of {item.name}")
            continue
        ctx.out.say(f"{p.servo.who} {item.name} = {show_value(p.servo.model, item, raw)}")
        docs.append(servo_doc(p.dxl_id, p.servo.model, p.baudrate, item=item.name, raw=raw,
                              value=to_unit(p.servo.model, item, raw), unit=unit_of(p.servo.model, item)))
    ctx.out.document.update(servos=docs, missing=found.missing + silent)
    if silent:
        raise StepFailed(f"ID {', '.join(map(str, silent))}: no reply to the sync read; the others were read")
    ctx.fail_if_missing(found, "the others were read")


def _wants(ctx: Context, found: list[Placed], value_of: Callable[[Placed, Item], int], name: str) -> list[Want]:
    wants = []
    for p in found:
        item = p.servo.item(name)
        if item.name in ("id", "baud_rate"):
            raise BadArguments(f"{p.servo.who}: {item.name} of several servos at once would make them collide: "
                               f"use set-{'id' if item.name == 'id' else 'baud'} on one")
        wants.append((p, item, value_of(p, item)))
    for p, item, raw in wants:  # every value checked before anything is written
        ctx.at(p)
        guard.check_values(ctx, p.servo, {item.name: raw})
    return wants


def _sync_write(ctx: Context, group: list[Want]) -> None:
    p0, item0, _ = group[0]
    ctx.at(p0)
    data = {p.dxl_id: encode(item, raw) for p, item, raw in group}
    done = ctx.bus.execute(ctx.bus.prepare_sync_write(item0.address, item0.size, data, protocol=p0.servo.protocol))
    if not done:
        raise StepFailed(f"sync write of {item0.name} to ID {', '.join(map(str, data))} failed: "
                         f"{done.why or 'not sent'}")
    # no status comes back: wait until the packet is out of the adapter before the bus may change rate
    packet = 14 + len(data) * (1 + item0.size)
    time.sleep(2 * ctx.bus.latency_timer_ms / 1000.0 + packet * 10.0 / ctx.bus.baudrate)


def _write(ctx: Context, changing: list[Want], torque: set[int]) -> None:
    """The sync writes, as one critical step: torque off where it was on, the item, torque back on
    with the goal where each servo is."""
    with held():
        for p, item, raw in changing:
            touched = JOURNAL.touch(p.dxl_id, p.servo.model.name, p.baudrate, "on" if p.dxl_id in torque else "as it was")
            touched.done.append(f"{item.name} -> {show_value(p.servo.model, item, raw)} (sync write)")
        off = [(p, p.servo.item("torque_enable"), 0) for p, _, _ in changing if p.dxl_id in torque]
        for group in _groups_of(off):
            _sync_write(ctx, group)
        try:
            for group in _groups_of(changing):
                _sync_write(ctx, group)
        finally:
            for p, _, _ in changing:
                if p.dxl_id in torque:
                    ctx.at(p).torque_on_in_place()


def _groups_of(wants: list[Want]) -> list[list[Want]]:
    groups: dict[tuple[int, int, int, int], list[Want]] = {}
    for want in wants:
        groups.setdefault((want[0].baudrate, want[1].address, want[1].size, want[0].servo.protocol), []).append(want)
    return list(groups.values())


def _confirm(ctx: Context, eeprom: list[Want], torque: bool) -> None:
    if eeprom:
        ctx.confirm(f"write {eeprom[0][1].name} (EEPROM) of ID {', '.join(str(w[0].dxl_id) for w in eeprom)}?"
                    + guard.torque_question(torque))


def _change(ctx: Context, found: list[Placed], wants: list[Want]) -> dict[str, Any]:
    by_id = {p.dxl_id: item for p, item, _ in wants}
    before = _read(ctx, found, lambda p: by_id[p.dxl_id])
    changing = [w for w in wants if before.get(w[0].dxl_id) != w[2]]
    torque = {p.dxl_id for p, item, _ in changing if guard.torque_gate(ctx, ctx.at(p), [item])}
    _confirm(ctx, [w for w in changing if w[1].eeprom], bool(torque))
    if changing:
        _write(ctx, changing, torque)
    after = _read(ctx, [w[0] for w in changing], lambda p: by_id[p.dxl_id])
    return {"before": before, "after": after, "changing": {w[0].dxl_id for w in changing}, "torque": torque}


def _report(ctx: Context, wants: list[Want], result: dict[str, Any]) -> list[str]:
    docs, wrong = [], []
    for p, item, raw in wants:
        model, was = p.servo.model, result["before"].get(p.dxl_id)
        shown = show_value(model, item, raw)
        doc = servo_doc(p.dxl_id, model, p.baudrate, item=item.name, raw=raw, before=was,
                        written=p.dxl_id in result["changing"])
        if p.dxl_id not in result["changing"]:
            ctx.out.say(f"{p.servo.who} {item.name} is already {shown}: nothing written")
        elif result["after"].get(p.dxl_id) != raw:
            got = result["after"].get(p.dxl_id)
            wrong.append(f"{p.servo.who}: {item.name} reads {'nothing' if got is None else show_value(model, item, got)} "
                         f"after writing {shown}")
            doc["failure"] = wrong[-1]
        else:
            ctx.out.say(f"{p.servo.who} {item.name} = {shown} (was {show_value(model, item, was) if was is not None else '?'}), "
                        "read back" + guard.torque_done(p.dxl_id in result["torque"]))
        docs.append(doc)
    ctx.out.document.update(servos=docs)
    return wrong


def _set(ctx: Context, args: argparse.Namespace, name: str, value_of: Callable[[Placed, Item], int],
         found: Found | None = None) -> None:
    found = found if found is not None else ctx.servos(args.id)
    _one_each(ctx, found.placed)
    wants = _wants(ctx, found.placed, value_of, name)
    wrong = _report(ctx, wants, _change(ctx, found.placed, wants)) if wants else []
    ctx.out.document.update(missing=found.missing)
    if wrong:
        raise StepFailed("; ".join(wrong))
    ctx.fail_if_missing(found, "the others were written")


def set_many(ctx: Context, args: argparse.Namespace) -> None:
    _set(ctx, args, args.item, lambda p, item: parse_value(p.servo.model, item, args.value, p.servo.who, raw=ctx.raw))


def mode_many(ctx: Context, args: argparse.Namespace) -> None:
    """Several servos' modes: Protocol 2.0 ones in one sync write per group; a Protocol 1.0 model
    (no Operating Mode: its Angle Limits) one at a time, each as ``set-mode ID``."""
    found = ctx.servos(args.id)
    old = [p for p in found.placed if p.servo.modes_by_limits]
    for p in old:
        ctx.at(p)
        guard.only_one(ctx, p.servo)
        set_mode1(ctx, p.servo, str(args.mode))
    rest = Found([p for p in found.placed if not p.servo.modes_by_limits], found.missing, found.rates)
    _set(ctx, args, "operating_mode", _mode_value(args), rest)


def _mode_value(args: argparse.Namespace) -> Callable[[Placed, Item], int]:

    def value(p: Placed, item: Item) -> int:
        text = str(args.mode).strip().lower()
        modes = p.servo.model.mode_values
        if text in modes:
            return modes[text]
        raise BadArguments(f"{p.servo.who}: {p.servo.model.name} has no operating mode '{text[:40]}' "
                           f"(one of {', '.join(modes)})")
    return value
