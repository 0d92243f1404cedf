"""``get``, ``set``, ``info`` and ``backup`` through a running handler node (``dynamixel/get_items``,
``dynamixel/set_items``; ``backup`` of every servo: the IDs of its ``dynamixel/manifest``): the same
output, files, JSON, exit codes and checks as the verbs on the bus.

Each servo's model is read first (its Model Number; Protocol Type tells the protocol it answers),
so values are parsed, checked and shown by the tool's own code; the node checks each write again
and writes it between two of its loop steps (it stays the bus's only writer). An EEPROM item of a
servo whose torque is on needs ``--torque-off`` (the node turns torque off for the write and back
on with goal := present), a value that lowers a protection ``--force``. A servo the node does not
handle is named in one line and the others done (exit 1)."""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from typing import Any, Sequence, TextIO, cast

from ..control_table import Item
from ..units import encode
from . import backup
from .checks import check, needed
from .context import confirm
from .errors import BadArguments, StepFailed
from .guard import torque_done, torque_question
from .items import find_item, parse_value, show_value, to_unit, unit_of
from .node_client import Entry, NodeClient
from .output import Output
from .protocol1 import any_model, protocol_of_type
from .safety import needs_torque_off, refuse_torque
from .servo import Servo
from .values import servo_doc
from .verbs_config import info_items, show_info

__all__ = ["NodeContext", "VERBS"]

#: what the node leaves to its own doors (set_items refuses them): where to go instead
_NOT_HERE = {
    "torque_enable": "torque goes on and off through the node's dynamixel/set_torque or the command topics",
    "operating_mode": "set-mode switches it through the node's own mode change",
    "protocol_type": "it changes the bus under the node: stop the node first",
}
_GOALS = ("goal_position", "goal_velocity", "goal_current", "goal_pwm")


class _NoBus:
    """What the verbs ask of a servo's bus, through the node: its rate, nothing known beyond the items."""

    def __init__(self, baudrate: int, device: str) -> None:
        self.baudrate = baudrate
        self.device = device
        self.firmware_versions: dict[int, int] = {}


@dataclass
class NodeServo(Servo):
    """A servo the node handles whose items were read through it (``values``: name -> raw)."""

    values: dict[str, int] = field(default_factory=dict)

    def read(self, name: str) -> int:
        item = self.item(name)
        if item.name not in self.values:
            raise StepFailed(f"{self.who}: {item.name} was not read through the node")
        return self.values[item.name]

    def read_block(self, first: Item, last: Item) -> bytes:
        """The bytes of the items from ``first`` to ``last`` as read through the node (gaps as 0)."""
        data = bytearray(last.address + last.size - first.address)
        for item in self.model.items.values():
            if first.address <= item.address <= last.address and item.name in self.values:
                at = item.address - first.address
                data[at:at + item.size] = bytes(encode(item, self.values[item.name]))[:item.size]
        return bytes(data)


@dataclass
class NodeContext:
    client: NodeClient
    out: Output
    yes: bool
    device: str = ""
    torque_off: bool = False
    force: bool = False
    raw: bool = False
    stdin: TextIO = sys.stdin
    #: ID -> the servo (model, protocol), the node's baud rate
    servos: dict[int, Servo] = field(default_factory=dict)
    baudrate: dict[int, int] = field(default_factory=dict)
    missing: list[int] = field(default_factory=list)

    def find(self, ids: Sequence[int]) -> list[Servo]:
        """The servos the node handles among ``ids``; each other one named in one line."""
        entries = self._identities(list(ids))
        for e, bps, kind in zip(entries[0::3], entries[1::3], entries[2::3]):
            if e.raw is None:
                self.out.error(f"ID {e.dxl_id}: {e.error} ({self.client.owner.node})")
                self.missing.append(e.dxl_id)
                continue
            model = any_model(e.raw)
            protocol = protocol_of_type(kind.raw) if kind.raw is not None else model.protocol
            self.baudrate[e.dxl_id] = model.baud_rates.get(bps.raw, 0) if bps.raw is not None else 0
            bus = cast(Any, _NoBus(self.baudrate[e.dxl_id], self.device))
            self.servos[e.dxl_id] = NodeServo(bus, e.dxl_id, model, protocol)
        return [self.servos[i] for i in ids if i in self.servos]

    def _identities(self, ids: list[int]) -> list[Entry]:
        """Model Number, Baud Rate and Protocol Type of ``ids``. The node refuses a request naming
        more servos than it handles: then the IDs its manifest does not list are named and left out."""
        names = ["model_number", "baud_rate", "protocol_type"]
        try:
            return self.client.get(ids, names)[1]
        except StepFailed:
            if len(ids) < 2:
                raise
            handled = set(self.client.handled())
        not_handled = [i for i in ids if i not in handled]
        for dxl_id in not_handled:
            self.out.error(f"ID {dxl_id}: not handled by this node ({self.client.owner.node})")
        self.missing += not_handled
        rest = [i for i in ids if i in handled]
        return self.client.get(rest, names)[1] if rest else []

    def read(self, servos: Sequence[Servo], names: Sequence[str]) -> dict[int, dict[str, int]]:
        """ID -> item -> raw; StepFailed naming the first item not read."""
        if not servos or not names:
            return {s.dxl_id: {} for s in servos}
        _, entries = self.client.get([s.dxl_id for s in servos], names)
        got: dict[int, dict[str, int]] = {}
        for e in entries:
            if e.raw is None:
                raise StepFailed(f"{self.servos[e.dxl_id].who}: reading {e.item} failed: {e.error}")
            got.setdefault(e.dxl_id, {})[e.item] = e.raw
        return got

    def doc(self, servo: Servo, **more: Any) -> dict[str, Any]:
        return servo_doc(servo.dxl_id, servo.model, self.baudrate[servo.dxl_id], **more)

    def fail_if_missing(self, done: str) -> None:
        if self.missing:
            ids = ", ".join(map(str, self.missing))
            raise StepFailed(f"{len(self.missing)} of {len(self.missing) + len(self.servos)} servo(s) not handled by "
                             f"the node (ID {ids}); {done}")


def _everything(ctx: NodeContext, servo: Servo) -> NodeServo:
    """``servo`` with every item but the indirect entries read through the node."""
    node_servo = cast(NodeServo, servo)
    node_servo.values = ctx.read([servo], [i.name for i in info_items(servo.model, False)])[servo.dxl_id]
    return node_servo


def backup_verb(ctx: NodeContext, args: argparse.Namespace) -> None:
    """``backup`` of the servos the node handles (every one, or the IDs given), read through it."""
    backup.check_paths(args)
    servos = ctx.find(args.ids if args.ids else ctx.client.handled())
    if not servos:
        raise StepFailed(f"the running node {ctx.client.owner.node} handles none of the servos asked for")
    backup.save(ctx.out, args, (_everything(ctx, s) for s in servos), ctx.device)
    ctx.out.document.update(missing=ctx.missing, servos=[ctx.doc(s) for s in servos])
    ctx.fail_if_missing(f"the others were saved to {args.file}")


def _item(servo: Servo, name: str) -> Item:
    return find_item(servo.model, name)


def get(ctx: NodeContext, args: argparse.Namespace) -> None:
    servos = ctx.find(args.id)
    items = {s.dxl_id: _item(s, args.item) for s in servos}
    values = ctx.read(servos, [items[servos[0].dxl_id].name]) if servos else {}
    docs = []
    for s in servos:
        item, raw = items[s.dxl_id], values[s.dxl_id][items[s.dxl_id].name]
        ctx.out.say(f"{s.who} {item.name} = {show_value(s.model, item, raw)}")
        docs.append(ctx.doc(s, item=item.name, raw=raw, value=to_unit(s.model, item, raw), unit=unit_of(s.model, item),
                            text=show_value(s.model, item, raw)))
    if len(args.id) == 1 and docs:
        ctx.out.document.update(docs[0])
    else:
        ctx.out.document.update(servos=docs, missing=ctx.missing)
    ctx.fail_if_missing("the others were read")


def _wanted(ctx: NodeContext, servo: Servo, args: argparse.Namespace) -> tuple[Item, int]:
    """The item and raw value for ``servo``; BadArguments as the verb on the bus says it."""
    item = _item(servo, args.item)
    if item.name in ("id", "baud_rate"):
        raise BadArguments(f"{servo.who}: use set-{'id' if item.name == 'id' else 'baud'} for {item.name} "
                           "(it checks the new address and finds the servo there), with the node stopped")
    if item.name in _NOT_HERE or item.name in _GOALS:
        why = _NOT_HERE.get(item.name, "a goal is given on the node's command topics or move_to")
        raise BadArguments(f"{servo.who}: {item.name} is not set through the running node: {why}")
    return item, parse_value(servo.model, item, args.value, servo.who, raw=ctx.raw)


def set_item(ctx: NodeContext, args: argparse.Namespace) -> None:
    servos = ctx.find(args.id)
    wants = {s.dxl_id: _wanted(ctx, s, args) for s in servos}
    if not servos:
        ctx.fail_if_missing("nothing was written")
    name = wants[servos[0].dxl_id][0].name
    extra = sorted({n for s in servos for n in needed(s.model, {name: wants[s.dxl_id][1]})} - {name})
    torque_item = ["torque_enable"] if all(s.model.has("torque_enable") for s in servos) else []
    now = ctx.read(servos, list(dict.fromkeys([name, *torque_item, *extra])))
    torque = _checked(ctx, servos, wants, name, now)
    changing = [s for s in servos if now[s.dxl_id][name] != wants[s.dxl_id][1]]
    eeprom = [s for s in changing if wants[s.dxl_id][0].eeprom]
    if eeprom:
        confirm(ctx.out, ctx.stdin, ctx.yes, _question(eeprom, name, wants, now) + torque_question(bool(torque)))
    _write_and_report(ctx, servos, changing, name, wants, now, torque, one=len(args.id) == 1)


def _checked(ctx: NodeContext, servos: list[Servo], wants: dict[int, tuple[Item, int]], name: str,
             now: dict[int, dict[str, int]]) -> set[int]:
    """Every value checked before anything is written (BadArguments, TorqueOn: exit 2); the IDs
    whose torque goes off for the write."""
    torque: set[int] = set()
    for s in servos:
        item, raw = wants[s.dxl_id]
        check(s.model, {name: raw}, now[s.dxl_id], s.who, ctx.force, s.dxl_id, ctx.servos)
        if needs_torque_off(item, s.model) and now[s.dxl_id].get("torque_enable") == 1:
            if not ctx.torque_off:
                raise refuse_torque(s, item)
            torque.add(s.dxl_id)
    return torque


def _question(eeprom: list[Servo], name: str, wants: dict[int, tuple[Item, int]], now: dict[int, dict[str, int]]) -> str:
    if len(eeprom) == 1:
        s = eeprom[0]
        item = wants[s.dxl_id][0]
        return (f"{s.who}: write {name} (EEPROM) from {show_value(s.model, item, now[s.dxl_id][name])} to "
                f"{show_value(s.model, item, wants[s.dxl_id][1])}?")
    return f"write {name} (EEPROM) of ID {', '.join(str(s.dxl_id) for s in eeprom)}?"


def _write_and_report(ctx: NodeContext, servos: list[Servo], changing: list[Servo], name: str,
                      wants: dict[int, tuple[Item, int]], now: dict[int, dict[str, int]], torque: set[int],
                      one: bool) -> None:
    after: dict[int, Any] = {}
    if changing:
        _, entries = ctx.client.set([s.dxl_id for s in changing], [name], [wants[s.dxl_id][1] for s in changing],
                                    ctx.force, bool(torque))
        after = {e.dxl_id: e for e in entries}
    docs, wrong = [], []
    for s in servos:
        item, raw = wants[s.dxl_id]
        was, shown = now[s.dxl_id][name], show_value(s.model, item, raw)
        doc = ctx.doc(s, item=item.name, raw=raw, before=was, written=s.dxl_id in after)
        if s.dxl_id not in after:
            ctx.out.say(f"{s.who} {name} is already {shown}: nothing written")
        elif after[s.dxl_id].raw != raw:
            wrong.append(f"{s.who}: {name} not written through the node: {after[s.dxl_id].error}")
            doc["failure"] = wrong[-1]
        else:
            ctx.out.say(f"{s.who} {name} = {shown} (was {show_value(s.model, item, was)}), read back"
                        + torque_done(s.dxl_id in torque))
        docs.append(doc)
    ctx.out.document.update(docs[0] if one else {"servos": docs, "missing": ctx.missing})
    if wrong:
        raise StepFailed("; ".join(wrong))
    ctx.fail_if_missing("the others were written")


def info(ctx: NodeContext, args: argparse.Namespace) -> None:
    servos = ctx.find([args.id])
    if not servos:
        ctx.fail_if_missing("nothing was read")
    servo = servos[0]
    items = info_items(servo.model, args.all)
    values = ctx.read([servo], [i.name for i in items])[servo.dxl_id]
    show_info(ctx.out, servo, ctx.baudrate[servo.dxl_id], items, values)


#: the verbs that go through the node
VERBS = {"get": get, "set": set_item, "info": info, "backup": backup_verb}
