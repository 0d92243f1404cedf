"""``restore FILE`` through a running handler node: the backup read and checked as on the bus
(``restore_file.py``), each servo's present EEPROM read through ``dynamixel/get_items``, the plan
worked out and checked before anything is written (``--dry-run`` shows it and stops), asked unless
``--yes``; then the items that differ written through ``dynamixel/set_items``, every servo of a
model in one request (the node checks them all again before the first write: one refused, nothing
written), each read back. The Operating Mode goes through the node's own mode change, as
``set-mode`` through the node (goals and profiles handled), before the other items. What changes
the bus under the node is not written and named as not done (exit 1): the Baud Rate and the
Protocol Type (restore them with the node stopped); a servo of the file the node does not handle is
not restored (a replacement is given its ID with the node stopped). An item equal on the servo is
never written."""
from __future__ import annotations

import argparse
from typing import Any, cast

from .context import confirm
from .errors import BadArguments, StepFailed
from .items import show_value
from .node_client import Entry as Answered
from .node_mode import wait_modes
from .node_verbs import NodeContext, NodeServo
from .restore import carry_out, restored_line
from .restore_file import Entry, kept, load
from .restore_plan import Plan, check_plan, plan_doc
from .servo import Servo

__all__ = ["restore_verb"]

#: items whose write changes the bus under the node: never written through it
_BUS = ("baud_rate", "protocol_type")


def _plan(ctx: NodeContext, entry: Entry, servo: Servo | None, path: str) -> tuple[Plan, dict[str, int]]:
    """One servo's plan from its present items read through the node; (plan, present raw values)."""
    plan = Plan(entry)
    if servo is None:
        plan.problem = (f"{entry.who}: not handled by the running node {ctx.client.owner.node}: not restored (a servo it "
                        "does not handle, or a replacement, is restored with the node stopped)")
        return plan, {}
    if servo.model.number != entry.model.number:
        raise BadArguments(f"{servo.who}: {path} holds a {entry.model.name} for ID {entry.dxl_id}: refused, nothing "
                           "written")
    node_servo = cast(NodeServo, servo)
    names = [i.name for i in servo.model.items.values() if kept(i)]
    torque = ["torque_enable"] if servo.model.has("torque_enable") else []
    node_servo.values = ctx.read([servo], names + torque)[servo.dxl_id]
    now = {n: node_servo.values[n] for n in names}
    plan.servo, plan.baudrate = servo, ctx.baudrate[servo.dxl_id]
    plan.torque = node_servo.values.get("torque_enable") == 1
    _differences(plan, servo, now)
    return plan, now


def _differences(plan: Plan, servo: Servo, now: dict[str, int]) -> None:
    """The items of the file that differ: to write (by address), or not written here and why."""
    model = plan.entry.model
    for name, raw in plan.entry.values.items():
        item = model.item(name)
        if name == "id" or now.get(name) == raw:
            continue
        why = ""
        if name in _BUS:
            why = "it changes the bus under the running node: restore it with the node stopped"
        elif name == "operating_mode" and servo.model.mode_name(raw) is None:
            why = "not a mode the node switches to"
        if why:
            plan.refused.append(f"{name} {show_value(model, item, raw)}: {why}; it stays "
                                f"{show_value(model, item, now[name])}")
        else:
            plan.changes.append((item, now[name], raw))
    plan.changes.sort(key=lambda c: c[0].address)


def _plans(ctx: NodeContext, entries: dict[int, Entry], path: str) -> list[Plan]:
    """Every servo's plan, all checked; BadArguments (one line, nothing written) on any problem."""
    servos = {s.dxl_id: s for s in ctx.find(sorted(entries))}
    planned = [_plan(ctx, entry, servos.get(dxl_id), path) for dxl_id, entry in sorted(entries.items())]
    ids = set(entries) | set(servos)
    found = [why for plan, now in planned if plan.servo is not None for why in check_plan(ctx, plan, now, ids)]
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise BadArguments(f"{found[0]}: refused, nothing written{more}")
    return [plan for plan, _ in planned]


def _text(plan: Plan, name: str, now: int, raw: int) -> str:
    item = plan.entry.model.item(name)
    return f"{name} {show_value(plan.entry.model, item, now)} -> {show_value(plan.entry.model, item, raw)}"


def _modes(ctx: NodeContext, plans: list[Plan], done: dict[int, list[str]], failed: dict[int, str]) -> None:
    """The Operating Modes, by the node's own mode change, then read back."""
    asked = {p.entry.dxl_id: (p, now, raw) for p in plans for item, now, raw in p.changes if item.name == "operating_mode"}
    for name in dict.fromkeys(p.entry.model.mode_name(raw) or "" for p, _, raw in asked.values()):
        group = {i: a for i, a in asked.items() if a[0].entry.model.mode_name(a[2]) == name}
        _switch(ctx, name, group, done, failed)


def _switch(ctx: NodeContext, name: str, group: dict[int, tuple[Plan, int, int]], done: dict[int, list[str]],
            failed: dict[int, str]) -> None:
    """The servos of ``group`` (ID -> plan, mode now, mode asked) switched to mode ``name``."""
    servos = [cast(Servo, plan.servo) for plan, _, _ in group.values()]
    ctx.client.switch_modes(list(group), name)
    after = wait_modes(ctx, servos, {i: raw for i, (_, _, raw) in group.items()})
    for s in servos:
        plan, now, raw = group[s.dxl_id]
        if after.get(s.dxl_id) == raw:
            done[s.dxl_id].append(_text(plan, "operating_mode", now, raw))
        else:
            failed[s.dxl_id] = (f"{s.who}: operating_mode reads {after.get(s.dxl_id, now)} after the node was asked "
                                f"for {name} (its log says why)")


def _items(ctx: NodeContext, plans: list[Plan], done: dict[int, list[str]], failed: dict[int, str]) -> None:
    """The other items, every servo of a model in one ``set_items`` request, each read back."""
    wanted = _wanted(plans)
    plans = [p for p in plans if wanted[p.entry.dxl_id]]
    for number in dict.fromkeys(p.entry.model.number for p in plans):
        group = [p for p in plans if p.entry.model.number == number]
        try:
            back = _request(ctx, group, wanted)
        except StepFailed as exc:
            failed.update({p.entry.dxl_id: f"{p.entry.who}: {exc}" for p in group})
            continue
        for p in group:
            _read_back(p, back, done, failed)


def _wanted(plans: list[Plan]) -> dict[int, dict[str, int]]:
    """ID -> item -> raw of what ``set_items`` writes (all but the Operating Mode)."""
    return {p.entry.dxl_id: {i.name: raw for i, _, raw in p.changes if i.name != "operating_mode"} for p in plans}


def _request(ctx: NodeContext, group: list[Plan], wanted: dict[int, dict[str, int]]) -> dict[tuple[int, str], Answered]:
    """One ``set_items`` request for ``group`` (servos of one model): every item one of them needs;
    one another servo has already is sent as it is (the node does not write an equal value)."""
    model = group[0].entry.model
    names = sorted({n for p in group for n in wanted[p.entry.dxl_id]}, key=lambda n: model.item(n).address)
    values = [wanted[p.entry.dxl_id].get(n, cast(NodeServo, p.servo).values[n]) for p in group for n in names]
    _, entries = ctx.client.set([p.entry.dxl_id for p in group], names, values, ctx.force, ctx.torque_off)
    return {(e.dxl_id, e.item): e for e in entries}


def _read_back(plan: Plan, back: dict[tuple[int, str], Answered], done: dict[int, list[str]],
               failed: dict[int, str]) -> None:
    """Each item of ``plan`` the node wrote, as it read it back."""
    dxl_id = plan.entry.dxl_id
    for item, now, raw in plan.changes:
        e = back.get((dxl_id, item.name))
        if e is None:
            continue  # the Operating Mode: written by the mode change
        if e.raw == raw:
            done[dxl_id].append(_text(plan, item.name, now, raw))
        else:
            failed.setdefault(dxl_id, f"{plan.entry.who}: {item.name} not written through the node: {e.error}")


def _run(ctx: NodeContext, plans: list[Plan]) -> tuple[list[dict[str, Any]], list[str]]:
    """Every servo's writes; (per servo: what was written and what not, the failures)."""
    todo = [p for p in plans if not p.problem and p.writes()]
    done: dict[int, list[str]] = {p.entry.dxl_id: [] for p in plans}
    failed: dict[int, str] = {}
    _modes(ctx, todo, done, failed)
    _items(ctx, [p for p in todo if p.entry.dxl_id not in failed], done, failed)
    report, failures = [], []
    for plan in plans:
        doc = plan_doc(plan)
        doc["written"] = done[plan.entry.dxl_id]
        report.append(doc)
        failure = _said(ctx, plan, done[plan.entry.dxl_id], failed.get(plan.entry.dxl_id, ""))
        if failure:
            doc["failure"] = failed.get(plan.entry.dxl_id)
            failures.append(failure)
    return report, failures


def _said(ctx: NodeContext, plan: Plan, done: list[str], failed: str) -> str:
    """The servo's line; what was not done ("" when it was)."""
    if plan.problem:
        return plan.problem
    if failed:
        ctx.out.error(f"{failed} (written before it: {', '.join(done) or 'nothing'})")
        return f"{failed} (written before it: {', '.join(done) or 'nothing'})"
    if not plan.writes():
        ctx.out.say(f"{plan.entry.who}: already as in the file, nothing written")
    else:
        ctx.out.say(restored_line(plan, done) + ("; torque was turned off for the writes and back on (goal := present "
                                                 "position)" if plan.torque else ""))
    return ""


def restore_verb(ctx: NodeContext, args: argparse.Namespace) -> None:
    carry_out(ctx.out, args, _plans(ctx, load(args.file), args.file),
              lambda question: confirm(ctx.out, ctx.stdin, ctx.yes, question), lambda plans: _run(ctx, plans))
