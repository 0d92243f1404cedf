"""What ``restore`` will write, worked out before anything is written (``--dry-run`` shows exactly
this): each servo of the backup found where the backup says, at another rate, or -- when it answers
nowhere -- the one unassigned servo of its model (a replacement, e.g. at factory ID 1 and 57600 bps)
to be given the backup's ID and rate first; then the items that differ. Every value is checked
(ranges, limit pairs, dangerous values, the torque rule) for every servo before the first write."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Protocol

from ..bus import BusError
from ..bus.ops import Ping
from ..control_table import Item
from .checks import problems
from .context import Context
from .errors import BadArguments
from .items import show_value
from .output import Output
from .per_protocol import tool_protocol
from .protocol1 import protocol_of_type
from .restore_file import Entry, present
from .safety import needs_torque_off, refuse_torque
from .servo import Servo, connect
from .values import servo_doc

__all__ = ["Plan", "Rules", "check_plan", "plan_all", "plan_doc"]


class Rules(Protocol):
    """What a plan's check asks of the verb: the owner's consents and where to warn."""

    force: bool
    torque_off: bool
    out: Output


@dataclass
class Plan:
    """One servo's part of a restore."""

    entry: Entry
    #: the servo as found now (None: not found, see ``problem``)
    servo: Servo | None = None
    #: the rate it answers at now
    baudrate: int = 0
    #: a replacement: found at another ID, given the backup's ID first
    replacement: bool = False
    #: the Baud Rate register value to write (its rate differs from the backup's), None: stays
    move_baud: int | None = None
    #: (item, now, from the file) for the other items that differ, in address order
    changes: list[tuple[Item, int, int]] = field(default_factory=list)
    #: what will not be written, and why (the others of this servo are)
    refused: list[str] = field(default_factory=list)
    #: why nothing is done for this servo ("" when it is restored)
    problem: str = ""
    #: its torque is on now (it goes off for the writes, with --torque-off)
    torque: bool = False

    @property
    def target_bps(self) -> int:
        return self.entry.baudrate or self.baudrate

    def writes(self) -> list[tuple[str, int, int]]:
        """(item, now, from the file), raw, of every write in the order they are made: ID, rate, items."""
        model = self.entry.model
        rows = []
        if self.servo is not None and self.servo.dxl_id != self.entry.dxl_id:
            rows.append(("id", self.servo.dxl_id, self.entry.dxl_id))
        if self.move_baud is not None:
            now = {bps: raw for raw, bps in model.baud_rates.items()}.get(self.baudrate, -1)
            rows.append(("baud_rate", now, self.move_baud))
        rows += [(item.name, now, raw) for item, now, raw in self.changes]
        return rows

    def shown(self) -> list[tuple[str, str, str]]:
        """``writes`` as a person reads them (units, codes by name)."""
        model = self.entry.model
        return [(name, show_value(model, model.item(name), now), show_value(model, model.item(name), new))
                for name, now, new in self.writes()]


def _at(ctx: Context, bps: int) -> bool:
    try:
        ctx.bus.set_baudrate(bps)
    except BusError:
        return False
    return True


def _in_place(ctx: Context, plans: dict[int, Plan], path: str) -> None:
    """Each servo at the backup's ID: at the backup's rate first (unless --baud), then at any rate."""
    def place(plan: Plan, servo: Servo, bps: int) -> None:
        if servo.model.number != plan.entry.model.number:
            raise BadArguments(f"{servo.who}: {path} holds a {plan.entry.model.name} for ID {plan.entry.dxl_id}: "
                               "refused, nothing written")
        plan.servo, plan.baudrate = servo, bps

    for plan in plans.values():
        bps = ctx.search.first if ctx.baud_given else (plan.entry.baudrate or ctx.search.first)
        protocol = plan.entry.model.protocol
        if _at(ctx, bps) and ctx.bus.execute(Ping(plan.entry.dxl_id, protocol=protocol)).value is not None:
            place(plan, connect(ctx.bus, plan.entry.dxl_id, protocol), bps)
    rest = [i for i, plan in plans.items() if plan.servo is None]
    if rest:
        for placed in ctx.search.find(rest).placed:
            place(plans[placed.dxl_id], placed.servo, placed.baudrate)


def _replacements(ctx: Context, plans: dict[int, Plan]) -> list[tuple[int, int, int]]:
    """The one unassigned servo of its model for each servo that answers nowhere; returns every
    servo seen (ID, rate, model number)."""
    seen = ctx.search.everywhere(also={p.entry.model.protocol for p in plans.values() if p.servo is None})
    free = _unassigned(seen, plans.values())
    missing = [p for p in plans.values() if p.servo is None]
    for plan in missing:
        number = plan.entry.model.number
        mine = [s for s in free if s[2] == number]
        rivals = [p.entry.dxl_id for p in missing if p.entry.model.number == number]
        if len(mine) == 1 and len(rivals) == 1:
            _take(ctx, plan, mine[0], seen)
        else:
            plan.problem = _no_replacement(plan.entry, mine, rivals)
    return seen


def _unassigned(seen: list[tuple[int, int, int]], plans: Iterable[Plan]) -> list[tuple[int, int, int]]:
    """The servos seen that no servo of the backup was found as."""
    claimed = {(p.servo.dxl_id, p.baudrate) for p in plans if p.servo is not None}
    return [s for s in seen if (s[0], s[1]) not in claimed]


def _no_replacement(entry: Entry, mine: list[tuple[int, int, int]], rivals: list[int]) -> str:
    if not mine:
        return f"{entry.who} answers at no rate and no unassigned {entry.model.name} answers to take its place: not restored"
    where = ", ".join(f"ID {i} at {b} bps" for i, b, _ in mine)
    return (f"{entry.who} answers at no rate; {len(mine)} unassigned {entry.model.name} ({where}) for "
            f"{len(rivals)} missing one(s) (ID {', '.join(map(str, rivals))}): which is its replacement "
            "cannot be told; connect one replacement at a time: not restored")


def _take(ctx: Context, plan: Plan, candidate: tuple[int, int, int], seen: list[tuple[int, int, int]]) -> None:
    dxl_id, bps, _ = candidate
    target = plan.entry.baudrate or bps
    taken = [(i, b) for i, b, _ in seen if i == plan.entry.dxl_id and b in (bps, target)]
    if taken:
        plan.problem = (f"{plan.entry.who}: its replacement (ID {dxl_id} at {bps} bps) would collide with the servo at "
                        f"ID {taken[0][0]}, {taken[0][1]} bps: not restored")
        return
    _at(ctx, bps)
    plan.servo, plan.baudrate, plan.replacement = connect(ctx.bus, dxl_id, plan.entry.model.protocol), bps, True


def _changes(ctx: Context, plan: Plan, seen: Iterable[tuple[int, int, int]]) -> dict[str, int]:
    """Fill ``plan``'s writes from the servo's present values; returns them."""
    assert plan.servo is not None
    _at(ctx, plan.baudrate)
    now = present(plan.servo)
    plan.torque = plan.servo.model.has("torque_enable") and plan.servo.torque_on()
    for name, raw in plan.entry.values.items():
        item = plan.entry.model.item(name)
        if name == "id":
            continue
        if name == "baud_rate":
            if plan.entry.baudrate != plan.baudrate:
                _baud_move(ctx, plan, raw, seen)
        elif now.get(name) != raw:
            plan.changes.append((item, now[name], raw))
    # by address; a Protocol Type last: after it the servo answers the other protocol only
    plan.changes.sort(key=lambda c: (c[0].name == "protocol_type", c[0].address))
    return now


def _baud_move(ctx: Context, plan: Plan, raw: int, seen: Iterable[tuple[int, int, int]]) -> None:
    target = plan.target_bps
    other = any(i == plan.entry.dxl_id and b == target for i, b, _ in seen)
    if not other and not plan.replacement:
        ping = Ping(plan.entry.dxl_id, protocol=plan.entry.model.protocol)
        other = _at(ctx, target) and ctx.bus.execute(ping).value is not None
        _at(ctx, plan.baudrate)
    if other:
        plan.refused.append(f"baud_rate {target} bps: another servo answers at ID {plan.entry.dxl_id} at {target} bps "
                            f"(they would collide); it stays at {plan.baudrate} bps")
    else:
        plan.move_baud = raw


def check_plan(ctx: Rules, plan: Plan, now: dict[str, int], ids: set[int]) -> list[str]:
    """Every reason the plan may not be carried out (the dangerous ones unless --force)."""
    assert plan.servo is not None
    new = {item.name: raw for item, _, raw in plan.changes}
    found = [f"{plan.entry.who}: {p.text}" + ("; --force writes it anyway" if p.forcible else "")
             for p in problems(plan.entry.model, new, now, plan.entry.dxl_id, ids - {plan.entry.dxl_id})
             if not (p.forcible and ctx.force)]
    found += _protocol_switch(ctx, plan)
    model = plan.entry.model
    off = [model.item(name) for name, _, _ in plan.writes() if needs_torque_off(model.item(name), model)]
    plan.torque = plan.torque and bool(off)  # a Protocol 1.0 model keeps its torque for all but its Angle Limits
    if plan.torque and not ctx.torque_off:
        found.append(str(refuse_torque(plan.servo, off[0])))
    return found


def _protocol_switch(ctx: Rules, plan: Plan) -> list[str]:
    """A Protocol Type in the file that switches a servo to a protocol ``set`` warns about (1, for a
    servo that answers Protocol 2.0): refused without --force (with it, the same warning as ``set``)."""
    assert plan.servo is not None
    for item, now, raw in plan.changes:
        if item.name != "protocol_type":
            continue
        new = protocol_of_type(raw)
        switch_warning = tool_protocol(new).switch_warning
        if new != plan.servo.protocol and switch_warning is not None:
            warning = switch_warning(plan.entry.who, plan.entry.dxl_id)
            if not ctx.force:
                return [f"{warning} (protocol_type {now} -> {raw} in the file); --force writes it anyway"]
            ctx.out.warn(warning)
    return []


def plan_all(ctx: Context, entries: dict[int, Entry], path: str) -> list[Plan]:
    """Every servo's plan, all checked; BadArguments (one line, nothing written) on any problem."""
    plans = {dxl_id: Plan(entry) for dxl_id, entry in sorted(entries.items())}
    _in_place(ctx, plans, path)
    seen: list[tuple[int, int, int]] = []
    if any(p.servo is None for p in plans.values()):
        seen = _replacements(ctx, plans)
    ids = set(plans) | {s[0] for s in seen}
    found: list[str] = []
    for plan in plans.values():
        if plan.servo is not None:
            found += check_plan(ctx, plan, _changes(ctx, plan, seen), ids)
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise BadArguments(f"{found[0]}: refused, nothing written{more}")
    return list(plans.values())


def plan_doc(plan: Plan) -> dict[str, Any]:
    """The plan in the JSON shape of a servo (``id``, ``model``, ``baudrate``: where it will be)."""
    after = plan.target_bps if plan.move_baud is not None else (plan.baudrate or plan.target_bps)
    return servo_doc(plan.entry.dxl_id, plan.entry.model, after,
                     found_at={"id": plan.servo.dxl_id, "baudrate": plan.baudrate} if plan.servo else None,
                     replacement=plan.replacement, problem=plan.problem or None,
                     writes=[{"item": i, "now": n, "file": f, "now_text": nt, "file_text": ft}
                             for (i, n, f), (_, nt, ft) in zip(plan.writes(), plan.shown())],
                     not_written=list(plan.refused))
