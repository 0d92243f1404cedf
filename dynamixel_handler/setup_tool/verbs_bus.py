"""The verbs about the bus as a whole: scan, assign-ids, reboot, factory-reset."""
from __future__ import annotations

import argparse
import time

from ..bus import DynamixelBus
from ..bus.ops import FactoryReset, Ping, Reboot
from ..protocol.framers import FRAMERS
from . import guard
from .context import Context
from .errors import BadArguments, StepFailed
from .find import Placed
from .per_protocol import tool_protocol
from .reset1 import reset_all_then_keep
from .safety import JOURNAL, Touched, held, reboot_consent, stopped
from .scan import COLUMNS, Found, scan_bus, scan_steps
from .servo import SEARCH_ORDER, Servo, connect
from .values import servo_doc

__all__ = ["scan", "assign_ids", "reboot", "factory_reset"]

#: how long a rebooted or reset servo may take to answer again [s]
_BACK_WITHIN_S = 3.0
#: where every servo is after a full factory reset (ROBOTIS e-Manual, Factory Reset 0xFF)
_FACTORY_ID, _FACTORY_BPS = 1, 57600
_RESET_OPTION = {"id": 0x01, "id,baud": 0x02, "all": 0xFF}


def _rates(args: argparse.Namespace) -> list[int]:
    return list(getattr(args, "rates", None) or SEARCH_ORDER)


def scan(ctx: Context, args: argparse.Namespace) -> None:
    rates = _rates(args)
    protocols = {"2": [2], "1": [1], "both": [2, 1]}[args.protocol or "both"]
    started = time.monotonic()
    with ctx.out.progress(scan_steps(rates, args.ids, protocols, ctx.bus.latency_timer_ms), "scanning") as tick:
        result = scan_bus(ctx.bus, rates, args.ids, protocols, tick)
    took = time.monotonic() - started
    styles = ["red" if f.collision or f.hardware_error else tool_protocol(f.protocol).row_style for f in result.found]
    ctx.out.table("", COLUMNS, [f.row() for f in result.found], styles)
    for bps, why in result.skipped.items():
        ctx.out.say(f"{bps} bps skipped: {why}")
    if result.interrupted_at is not None:
        done = rates[:rates.index(result.interrupted_at)] if result.interrupted_at in rates else []
        ctx.out.say(f"scan interrupted at {result.interrupted_at} bps after {took:.1f} s: {len(result.found)} servo(s) "
                    f"found until then (rates looked at in full: {', '.join(map(str, done)) or 'none'})")
        ctx.out.document.update(result.as_dict(), seconds=round(took, 2), interrupted=True)
        raise stopped()
    ctx.out.say(f"{len(result.found)} servo(s) found at {len(rates) - len(result.skipped)} baud rate(s), "
                f"IDs {args.ids[0]}-{args.ids[-1]}, in {took:.1f} s")
    ctx.out.document.update(result.as_dict(), seconds=round(took, 2))


def _wait_back(bus: DynamixelBus, dxl_id: int, protocol: int = 2) -> int | None:
    """The model number once ``dxl_id`` answers again (after a reboot or reset), None if it does not."""
    deadline = time.monotonic() + _BACK_WITHIN_S
    while time.monotonic() < deadline:
        time.sleep(0.1)
        number: int | None = bus.execute(Ping(dxl_id, retries=0, protocol=protocol)).value
        if number is not None:
            return number
    return None


def reboot(ctx: Context, args: argparse.Namespace) -> None:
    """``reboot ID``, ``reboot 1,2,5`` or ``reboot all`` (every servo at every rate unless --baud);
    each one waited for and reported, a missing one named without failing the others. A reboot drops
    torque: a servo holding its load is refused unless --torque-off (and asked about without --yes);
    with it torque comes back on after the reboot, the goal where the servo is."""
    found = ctx.servos(args.id)
    for placed in found.placed if args.id is not None else []:  # `all` found each ID at one rate only
        guard.only_one(ctx, ctx.at(placed))
    holding = _holding(ctx, found.placed)
    failed, rebooted = [], []
    for placed in found.placed:
        servo = ctx.at(placed)
        torque = placed.dxl_id in holding
        why = _reboot_one(ctx, servo, placed.baudrate, torque)
        if why:
            failed.append(f"{servo.who}: reboot failed: {why}")
        else:
            rebooted.append(servo_doc(servo.dxl_id, servo.model, placed.baudrate))
            ctx.out.say(f"{servo.who} rebooted and answers again" + (", torque back on (goal := present position)"
                                                                        if torque else ""))
    ctx.out.document.update(rebooted=[s["id"] for s in rebooted], servos=rebooted, failed=failed,
                            missing=found.missing)
    if failed:
        raise StepFailed("; ".join(failed))
    ctx.fail_if_missing(found, f"{len(rebooted)} rebooted")


def _reboot_one(ctx: Context, servo: Servo, baudrate: int, torque: bool) -> str:
    """Reboot ``servo`` as one critical step, torque back on (goal := present) if it was; why it
    failed ("" when it answers again)."""
    with held():
        entry = JOURNAL.touch(servo.dxl_id, servo.model.name, baudrate, "on" if torque else "off")
        done = servo.execute(Reboot(servo.dxl_id, protocol=servo.protocol))
        if not done:
            return _no_reboot(ctx, servo, entry, torque) or done.why or "no reply"
        if _wait_back(ctx.bus, servo.dxl_id, servo.protocol) is None:
            entry.torque = "unknown (it does not answer)"
            return f"it does not answer within {_BACK_WITHIN_S:.0f} s"
        entry.torque, entry.done = "off (rebooted)" if torque else "off", entry.done + ["rebooted"]
        if torque:
            servo.torque_on_in_place()
            entry.torque = "on (as before)"
    return ""


def _no_reboot(ctx: Context, servo: Servo, entry: Touched, torque: bool) -> str:
    """Why a Protocol 1.0 servo did not reboot when it answered the Reboot instruction with the
    Instruction Error bit (AX, RX and the other models without it; ``ToolProtocol.no_reboot``): ""
    for any other failure."""
    if not tool_protocol(servo.protocol).no_reboot(servo.status_error):
        return ""
    entry.torque = "on (as before: not rebooted)" if torque else "off"
    return (f"the {servo.model.name} has no reboot instruction (Protocol 1.0: it answers Instruction Error); "
            "power-cycle it (an overload or overheating shutdown also clears when Torque Limit is written again)")


def _holding(ctx: Context, placed: list[Placed]) -> set[int]:
    """The IDs of ``placed`` whose torque is on; refused (TorqueOn, nothing rebooted) unless
    --torque-off, and asked about without --yes."""
    holding = {p.dxl_id for p in placed if ctx.at(p).model.has("torque_enable") and ctx.at(p).torque_on()}
    reboot_consent(holding, len(placed), ctx.torque_off, ctx.confirm)
    return holding


def _check_free_after_reset(ctx: Context, servo: Servo, level: str) -> None:
    """Refuse a reset that would put the servo where another one answers (it would collide there)."""
    where_id = servo.dxl_id if level != "all" else _FACTORY_ID
    where_bps = ctx.bus.baudrate if level == "id,baud" else _FACTORY_BPS
    if (where_id, where_bps) == (servo.dxl_id, ctx.bus.baudrate):
        return
    here = ctx.bus.baudrate
    ctx.bus.set_baudrate(where_bps)
    other = ctx.bus.execute(Ping(where_id, retries=1, protocol=2)).value
    ctx.bus.set_baudrate(here)
    if other is not None:
        raise StepFailed(f"{servo.who}: after this reset it would answer at ID {where_id}, {where_bps} bps, where another "
                         f"servo (model {other}) answers: they would collide; nothing was reset")


def _reset(ctx: Context, servo: Servo, level: str, torque: bool, where: tuple[int, int]) -> None:
    """The factory reset as one critical step: torque off (if on), reset, found again at ``where``."""
    where_id, where_bps = where
    with held():
        entry = JOURNAL.touch(servo.dxl_id, servo.model.name, ctx.bus.baudrate, "on" if torque else "off")
        if torque:
            servo.write("torque_enable", 0)
            entry.torque = "off (it was on)"
        reset = ctx.bus.execute(FactoryReset(servo.dxl_id, _RESET_OPTION[level], protocol=servo.protocol))
        if not reset:
            raise StepFailed(f"{servo.who}: factory reset refused: {reset.why or 'no reply'}; nothing was "
                             f"reset (torque {entry.torque})")
        entry.done.append(f"factory reset (keeping {level if level != 'all' else 'nothing'}) sent")
        entry.dxl_id, entry.baudrate = where_id, where_bps
        ctx.bus.set_baudrate(where_bps)
        if _wait_back(ctx.bus, where_id) is None:
            raise StepFailed(f"{servo.who}: reset sent, but no servo answers at ID {where_id}, {where_bps} bps afterwards")
        entry.done[-1] = entry.done[-1].replace(" sent", " done")


def factory_reset(ctx: Context, args: argparse.Namespace) -> None:
    level = "all" if args.all else args.keep
    servo = ctx.servo(args.id)
    if not FRAMERS[servo.protocol].reset_option:  # Protocol 1.0: everything is reset, ID and baud rate too
        reset_all_then_keep(ctx, servo, level, _wait_back)
        return
    keeps = {"all": "nothing: it comes back as ID 1 at 57600 bps", "id": "its ID (baud rate back to 57600)",
             "id,baud": "its ID and baud rate"}[level]
    guard.only_one(ctx, servo)
    _check_free_after_reset(ctx, servo, level)
    torque = guard.torque_for(ctx, servo, "a factory reset")
    ctx.confirm(f"{servo.who}: factory reset of every EEPROM item, keeping {keeps}?"
                + (" Its torque is on: it goes off and stays off (the factory state)." if torque else ""))
    where_id = servo.dxl_id if level != "all" else _FACTORY_ID
    where_bps = ctx.bus.baudrate if level == "id,baud" else _FACTORY_BPS
    _reset(ctx, servo, level, torque, (where_id, where_bps))
    ctx.out.say(f"{servo.who}: factory reset done; it answers at ID {where_id}, {where_bps} bps"
                + (", torque off (the factory state)" if torque else ""))
    ctx.out.document.update(id=where_id, baudrate=where_bps, kept=level)


# ------------------------------------------------------------------------------- assign-ids
def _look(ctx: Context, rates: list[int], ids: list[int]) -> list[Found]:
    """The servos at ``rates`` x ``ids``: Protocol 2.0, and 1.0 too with ``--protocol 1`` or ``both``."""
    protocols = {"1": [1], "both": [2, 1]}.get(ctx.protocols or "", [2])
    with ctx.out.progress(scan_steps(rates, ids, protocols, ctx.bus.latency_timer_ms), "looking for servos") as tick:
        return scan_bus(ctx.bus, rates, ids, protocols, tick).found


def _next_id(start: int, taken: set[int]) -> int:
    new = start
    while new in taken:
        new += 1
    if new > 252:
        raise StepFailed("no free ID left (0..252)")
    return new


def _give(ctx: Context, new: Found, new_id: int, target: int) -> Servo:
    """Move the servo found at ``new`` to ``new_id`` and ``target`` bps; returns it there."""
    bus, protocol = ctx.bus, new.protocol
    bus.set_baudrate(new.baudrate)
    servo = connect(bus, new.dxl_id, protocol)
    if new_id != servo.dxl_id:
        if bus.execute(Ping(new_id, retries=1, protocol=protocol)).value is not None:
            raise StepFailed(f"{servo.who}: ID {new_id} is in use at {new.baudrate} bps; not changed")
        servo.set_checked("id", new_id, after=lambda: connect(bus, new_id, protocol), torque_off=ctx.torque_off)
        servo = connect(bus, new_id, protocol)
    if target != new.baudrate:
        by_bps = {bps: value for value, bps in servo.model.baud_rates.items()}
        if target not in by_bps:
            raise StepFailed(f"{servo.who} cannot use {target} bps; it keeps {new.baudrate} bps")

        def there() -> Servo:
            bus.set_baudrate(target)
            return connect(bus, new_id, protocol)

        servo.set_checked("baud_rate", by_bps[target], after=there, torque_off=ctx.torque_off)
    bus.set_baudrate(target)
    return connect(bus, new_id, protocol)


def _forget(known: set[tuple[int, int]], clash: list[Found]) -> None:
    """Where a new servo collided with a known one, either may be the one left connected next."""
    known.difference_update((f.dxl_id, f.baudrate) for f in clash)


def _one_round(ctx: Context, known: set[tuple[int, int]], rates: list[int], ids: list[int],
               next_id: int, target: int) -> tuple[Found, Servo] | None:
    seen = _look(ctx, rates, ids)
    clash = [f for f in seen if f.collision and (f.dxl_id, f.baudrate) in known]
    if clash:
        where = ", ".join(f"ID {f.dxl_id} at {f.baudrate} bps" for f in clash)
        _forget(known, clash)
        ctx.out.say(f"the new servo answers where another one is ({where}): two or more servos answer as one there "
                    "and no write can tell them apart; disconnect all of them but one and press Enter: each one "
                    "connected alone then gets its own ID here")
        return None
    found = [f for f in seen if (f.dxl_id, f.baudrate) not in known]
    if not found:
        ctx.out.say("no new servo found: is it connected and powered? Press Enter to look again")
        return None
    if len(found) > 1 or found[0].collision:
        ctx.out.say(f"{len(found)} new servos answer ({', '.join(f'ID {f.dxl_id} at {f.baudrate} bps' for f in found)}): "
                    "connect one at a time; press Enter when only one new servo is connected")
        return None
    with held():  # its ID and its rate are one step: a signal waits until it answers at both
        return found[0], _give(ctx, found[0], next_id, target)


class _Assigner:
    """assign-ids' state: the addresses known, the IDs taken at the target rate, what was done."""

    def __init__(self, ctx: Context, args: argparse.Namespace) -> None:
        self.ctx = ctx
        self.rates = list(args.search_baud or SEARCH_ORDER)
        self.ids: list[int] = args.ids
        self.start: int = args.start
        self.target = ctx.bus.baudrate if ctx.baud_given else _FACTORY_BPS
        self.known = {(f.dxl_id, f.baudrate) for f in _look(ctx, self.rates, self.ids)}
        self.taken = {i for i, bps in self.known if bps == self.target}
        self.assigned: list[dict[str, object]] = []
        self.failures: list[str] = []

    def next_id(self) -> int:
        new = _next_id(self.start, self.taken)
        if (new, self.target) == (_FACTORY_ID, _FACTORY_BPS):
            raise BadArguments(f"ID {_FACTORY_ID} at {_FACTORY_BPS} bps is where every new servo arrives: the next one "
                               "would collide with it; start at 2 or more, or give --baud")
        return new

    def one(self, next_id: int) -> None:
        """Find the one new servo and give it ``next_id`` and the target rate (a failure is said and kept)."""
        ctx = self.ctx
        try:
            got = _one_round(ctx, self.known, self.rates, self.ids, next_id, self.target)
        except StepFailed as exc:  # this servo only: say why and let the person try again or go on
            self.failures.append(str(exc))
            ctx.out.error(f"{exc}; press Enter to look again, or q")
            return
        if got is None:
            return
        was, servo = got
        self.known.add((next_id, self.target))
        self.taken.add(next_id)
        self.assigned.append(servo_doc(next_id, servo.model, self.target, was_id=was.dxl_id,
                                       was_baudrate=was.baudrate))
        ctx.out.say(f"{servo.model.name}: ID {was.dxl_id} at {was.baudrate} bps -> ID {next_id} at {self.target} bps, "
                    "verified")


def assign_ids(ctx: Context, args: argparse.Namespace) -> None:
    job = _Assigner(ctx, args)
    ctx.out.say(f"{len(job.known)} servo(s) already on the bus; new servos get IDs from {args.start} at {job.target} bps")
    while True:
        next_id = job.next_id()
        ctx.out.say(f"Connect one new servo and press Enter (it gets ID {next_id}); q and Enter to finish")
        line = ctx.line()
        if line is None or line.strip().lower() in ("q", "quit", "done"):
            break
        job.one(next_id)
    ctx.out.table("assigned", ["ID", "model", "was ID", "was baud"],
                  [[a["id"], a["model"], a["was_id"], a["was_baudrate"]] for a in job.assigned])
    ctx.out.document.update(assigned=job.assigned, baudrate=job.target, failures=job.failures)
    if job.failures:
        raise StepFailed(f"{len(job.failures)} step(s) failed during assign-ids, the last: {job.failures[-1]}")
