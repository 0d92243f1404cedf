"""What a verb checks before it writes to a servo: the values (:mod:`.checks`, with the present
values they need read first), the torque rule (torque is the owner's to give: ``--torque-off``),
and that the servo it found is the only one at its ID (one ID answering at two rates is refused,
both named). Also the words the confirmation and the result use for the torque."""
from __future__ import annotations

from typing import Iterable, Mapping

from ..bus import BusError
from ..bus.ops import Ping
from ..control_table import Item
from .checks import check, needed
from .context import Context
from .errors import StepFailed
from .per_protocol import tool_protocol
from .safety import TorqueOn, needs_torque_off, refuse_torque
from .servo import Servo

__all__ = ["check_values", "torque_gate", "torque_for", "torque_question", "torque_done", "only_one"]


def check_values(ctx: Context, servo: Servo, new: Mapping[str, int]) -> None:
    """BadArguments (nothing sent) when ``new`` (item -> raw) breaks a range, a limit pair or needs
    ``--force``; the present values the checks need are read from the servo."""
    now = {name: servo.read(name) for name in needed(servo.model, new)}
    others: Iterable[int] = ()
    if "secondary_id" in new:
        others = ctx.bus.scan(range(253), broadcast=True)
    check(servo.model, new, now, servo.who, ctx.force, servo.dxl_id, others)


def torque_gate(ctx: Context, servo: Servo, items: Iterable[Item]) -> bool:
    """Whether the servo's torque is on and must go off for ``items``; TorqueOn (exit 2, nothing
    written) when it is and ``--torque-off`` was not given."""
    for item in items:
        if needs_torque_off(item, servo.model) and servo.model.has("torque_enable") and servo.torque_on():
            if not ctx.torque_off:
                raise refuse_torque(servo, item)
            return True
    return False


def torque_for(ctx: Context, servo: Servo, action: str) -> bool:
    """Whether the servo's torque is on for ``action`` (a factory reset), which turns it off;
    TorqueOn (exit 2, nothing done) when it is and ``--torque-off`` was not given."""
    if not (servo.model.has("torque_enable") and servo.torque_on()):
        return False
    if not ctx.torque_off:
        raise TorqueOn(f"{servo.who}: torque is on and {action} turns it off, which lets go of the load it holds: "
                       "refused, nothing done (give --torque-off to allow it)")
    return True


def torque_question(on: bool) -> str:
    """What the confirmation adds when the torque goes off for the write."""
    return (" Its torque is on: it goes off for the write (the load is not held meanwhile), then back on "
            "with the goal where it is.") if on else ""


def torque_done(on: bool) -> str:
    return "; torque was turned off for the write and back on (goal := present position)" if on else ""


def only_one(ctx: Context, servo: Servo) -> None:
    """StepFailed naming both rates when one ``--baud`` rate was not given and another servo answers
    at the same ID at another rate looked at (which one is meant cannot be told); the bus is left at
    the servo's rate."""
    if ctx.baud_given:
        return
    here = ctx.bus.baudrate
    try:
        for bps in ctx.search.rates():
            if bps == here:
                continue
            try:
                ctx.bus.set_baudrate(bps)
            except BusError:
                continue
            if not tool_protocol(servo.protocol).may_be_at(bps):
                continue
            if ctx.bus.execute(Ping(servo.dxl_id, retries=0, protocol=servo.protocol)).value is not None:
                raise StepFailed(f"ID {servo.dxl_id} answers at {here} and at {bps} bps: two servos have it; refused, "
                                 "nothing written (give --baud to choose one)")
    finally:
        ctx.bus.set_baudrate(here)
