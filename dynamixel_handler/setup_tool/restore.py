"""``restore FILE``: a backup written back. The file is read with limits and every item checked
(:mod:`.restore_file`), every servo found and every write worked out and checked before the first
one (:mod:`.restore_plan`; ``--dry-run`` prints exactly that and stops), then each servo in one
critical step (signals held: torque off if it was on, ID and rate first for a replacement, the
items, each read back, torque back on with the goal where it is). A servo that is missing or
fails is reported and the others are restored; the report says what was written and what not."""
from __future__ import annotations

import argparse
from typing import Any, Callable

from .context import Context
from .errors import StepFailed
from .find import Placed
from .items import show_value
from .output import Output
from .protocol1 import protocol_of_type
from .restore_file import load
from .restore_plan import Plan, plan_all, plan_doc
from .safety import JOURNAL, Interrupted, Touched, held
from .servo import Servo, connect

__all__ = ["restore", "show_plans", "question", "finish", "restored_line", "dry_run"]


def _rows(plans: list[Plan]) -> list[list[object]]:
    rows: list[list[object]] = []
    for plan in plans:
        if plan.problem:
            rows.append([plan.entry.dxl_id, "-", "", plan.problem])
            continue
        for item, now, new in plan.shown():
            rows.append([plan.entry.dxl_id, item, now, new])
        for why in plan.refused:
            rows.append([plan.entry.dxl_id, why.split(" ", 1)[0], "", f"not written: {why.split(': ', 1)[-1]}"])
    return rows


def _written(servo: Servo, touched: Touched, name: str, now: str, raw: int) -> str:
    text = f"{name} {now} -> {show_value(servo.model, servo.item(name), raw)}"
    touched.done.append(f"{text} written and read back")
    return text


def _verify(servo: Servo, name: str, raw: int) -> None:
    got = servo.read(name)
    if got != raw:
        raise StepFailed(f"{servo.who}: {name} reads {show_value(servo.model, servo.item(name), got)} after writing "
                         f"{show_value(servo.model, servo.item(name), raw)}")


def _move(ctx: Context, plan: Plan, servo: Servo, touched: Touched, done: list[str]) -> Servo:
    """A replacement's new ID, then the backup's rate: each found again and read back."""
    new_id = plan.entry.dxl_id
    if servo.dxl_id != new_id:
        was = str(servo.dxl_id)
        servo.write("id", new_id)
        servo = connect(ctx.bus, new_id, servo.protocol)
        _verify(servo, "id", new_id)
        touched.dxl_id = new_id
        done.append(_written(servo, touched, "id", was, new_id))
    if plan.move_baud is not None:
        was = show_value(servo.model, servo.item("baud_rate"), servo.read("baud_rate"))
        servo.write("baud_rate", plan.move_baud)
        touched.done.append(f"baud_rate -> {plan.target_bps} bps sent")
        ctx.bus.set_baudrate(plan.target_bps)
        servo = connect(ctx.bus, new_id, servo.protocol)
        _verify(servo, "baud_rate", plan.move_baud)
        touched.baudrate = plan.target_bps
        touched.done.pop()
        done.append(_written(servo, touched, "baud_rate", was, plan.move_baud))
    return servo


def _apply(ctx: Context, plan: Plan, done: list[str]) -> None:
    """One servo's writes as one critical step; ``done`` gets each write read back."""
    assert plan.servo is not None
    servo = ctx.at(Placed(plan.servo, plan.baudrate))
    touched = JOURNAL.touch(servo.dxl_id, servo.model.name, plan.baudrate, "on" if plan.torque else "off")
    with held():
        if plan.torque:
            servo.write("torque_enable", 0)
            touched.torque = "off (it was on; the load is not held)"
        try:
            servo = _move(ctx, plan, servo, touched, done)
            for item, now, raw in plan.changes:
                servo.write(item.name, raw)
                if item.name == "protocol_type":  # the last write: found again in the protocol it answers now
                    servo = connect(ctx.bus, servo.dxl_id, protocol_of_type(raw))
                _verify(servo, item.name, raw)
                done.append(_written(servo, touched, item.name, show_value(servo.model, item, now), raw))
        finally:
            if plan.torque:
                servo.torque_on_in_place()
                touched.torque = "on (as before)"


def restored_line(plan: Plan, done: list[str]) -> str:
    return f"{plan.entry.who}{' (replacement)' if plan.replacement else ''}: written and read back: {'; '.join(done)}"


def _run(ctx: Context, plans: list[Plan]) -> tuple[list[dict[str, Any]], list[str]]:
    """Every servo's writes; (per servo: what was written and what not, the failures)."""
    report, failures = [], []
    for plan in plans:
        doc = plan_doc(plan)
        done: list[str] = []
        doc["written"] = done
        report.append(doc)
        if plan.problem:
            failures.append(plan.problem)
            continue
        if not plan.writes():
            ctx.out.say(f"{plan.entry.who}: already as in the file, nothing written")
            continue
        try:
            _apply(ctx, plan, done)
        except Interrupted:
            raise
        except StepFailed as exc:
            doc["failure"] = str(exc)
            failures.append(f"{exc} (written before it: {', '.join(done) or 'nothing'})")
            ctx.out.error(failures[-1])
            continue
        ctx.out.say(restored_line(plan, done))
    return report, failures


def show_plans(out: Output, plans: list[Plan], args: argparse.Namespace) -> list[str]:
    """The table of every write (the dry run's answer); returns what will not be done."""
    rows = _rows(plans)
    if rows:
        out.table(f"restore from {args.file}", ["ID", "item", "now", "from the file"], rows)
    out.document.update(file=args.file, dry_run=bool(args.dry_run), servos=[plan_doc(p) for p in plans],
                            changes=[{"id": p.entry.dxl_id, "item": i, "now": n, "file": f}
                                     for p in plans for i, n, f in p.writes()])
    return [p.problem for p in plans if p.problem] + [w for p in plans for w in p.refused]


def question(plans: list[Plan], writes: int) -> str:
    torque = any(p.torque and p.writes() for p in plans)
    moved = [f"ID {p.servo.dxl_id} at {p.baudrate} bps becomes ID {p.entry.dxl_id}" for p in plans
             if p.replacement and p.servo is not None]
    return (f"write these {writes} EEPROM item(s)?" +
            (f" Replacement(s): {'; '.join(moved)} (ID and rate first, then its items)." if moved else "") +
            (" Servos with torque on have it turned off for their writes and back on after." if torque else ""))


def carry_out(out: Output, args: argparse.Namespace, plans: list[Plan], confirm: Callable[[str], None],
              run: Callable[[list[Plan]], tuple[list[dict[str, Any]], list[str]]]) -> None:
    """A restore's plans shown, stopped there on ``--dry-run``, asked (``confirm``) when anything is
    to be written, carried out (``run``: on the bus, or through a running node) and summed up."""
    skipped = show_plans(out, plans, args)
    writes = sum(len(p.writes()) for p in plans)
    if dry_run(out, args, writes, skipped):
        return
    if writes:
        confirm(question(plans, writes))
    report, failures = run(plans)
    finish(out, report, failures, skipped, writes)


def restore(ctx: Context, args: argparse.Namespace) -> None:
    carry_out(ctx.out, args, plan_all(ctx, load(args.file), args.file), ctx.confirm, lambda plans: _run(ctx, plans))


def dry_run(out: Output, args: argparse.Namespace, writes: int, skipped: list[str]) -> bool:
    """True when nothing is to be done: a dry run (StepFailed when the real run would be
    incomplete), or every servo as in the file."""
    if args.dry_run:  # the exit code the real run would give: 1 when it would be incomplete
        if skipped:
            raise StepFailed(f"dry run: {writes} item(s) would be written, nothing written; the real run would be "
                             f"incomplete: {'; '.join(dict.fromkeys(skipped))}")
        out.say(f"dry run: {writes} item(s) would be written, nothing written")
        return True
    if not writes and not skipped:
        out.say(f"every servo already matches {args.file}: nothing written")
        return True
    return False


def finish(out: Output, report: list[dict[str, Any]], failures: list[str], skipped: list[str], writes: int) -> None:
    """The report in the document, the last line; StepFailed when something was not done."""
    out.document.update(servos=report)
    written = sum(len(r["written"]) for r in report)
    if failures or skipped:
        not_done = list(dict.fromkeys(failures + skipped))
        raise StepFailed(f"restore incomplete: {written} item(s) written and read back; not done: {'; '.join(not_done)}")
    if writes:
        out.say(f"{written} item(s) written and read back")
