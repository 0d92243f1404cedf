"""``factory-reset`` of a servo that answers Protocol 1.0. Its Reset instruction has no option: it
resets every item, the ID to 1 and the baud rate to the model's factory rate (1 Mbps on AX and
MX-12W, 57,600 bps on the others; a 2.0 model set to Protocol Type 1 comes back answering Protocol
2.0 at its factory ID and rate). The tool looks for it there, says so, and for ``--keep id`` /
``--keep id,baud`` writes the ID (and the baud rate) back, each found again and read back, all in
one critical step; before anything is sent it refuses when another servo answers where the reset
or the kept ID would put it (they would collide)."""
from __future__ import annotations

from typing import Callable

from ..bus import DynamixelBus
from ..bus.ops import FactoryReset, Ping
from . import guard
from .context import Context
from .errors import StepFailed
from .safety import JOURNAL, Touched, held
from .servo import Servo, connect

__all__ = ["reset_all_then_keep", "factory_place"]

WaitBack = Callable[[DynamixelBus, int, int], "int | None"]


def factory_place(servo: Servo) -> tuple[int, int, int]:
    """(ID, rate, protocol) a full reset puts ``servo`` at: its model's factory values."""
    model = servo.model
    bps = model.baud_rates.get(model.factory.get("baud_rate", -1), 57600)
    return model.factory.get("id", 1), bps, model.protocol


def _free(ctx: Context, servo: Servo, where: tuple[int, int, int], why: str) -> None:
    dxl_id, bps, protocol = where
    here = ctx.bus.baudrate
    if (dxl_id, bps) == (servo.dxl_id, here):
        return
    ctx.bus.set_baudrate(bps)
    other = ctx.bus.execute(Ping(dxl_id, retries=1, protocol=protocol)).value
    ctx.bus.set_baudrate(here)
    if other is not None:
        raise StepFailed(f"{servo.who}: {why} ID {dxl_id} at {bps} bps, where another servo (model {other}) answers: "
                         "they would collide; nothing was reset")


def _keep(ctx: Context, back: Servo, entry: Touched, dxl_id: int, bps: int | None) -> Servo:
    """The reset servo given its ID (and rate) back, each found again there and read back."""
    bus, protocol = ctx.bus, back.protocol
    if back.dxl_id != dxl_id:
        back.set_checked("id", dxl_id, after=lambda: connect(bus, dxl_id, protocol), torque_off=True)
        back = connect(bus, dxl_id, protocol)
        entry.dxl_id = dxl_id
    if bps is not None and bps != bus.baudrate:
        value = {rate: v for v, rate in back.model.baud_rates.items()}[bps]

        def there() -> Servo:
            bus.set_baudrate(bps)
            return connect(bus, dxl_id, protocol)

        back.set_checked("baud_rate", value, after=there, torque_off=True)
        back = connect(bus, dxl_id, protocol)
        entry.baudrate = bps
    return back


def _reset(ctx: Context, servo: Servo, torque: bool, factory: tuple[int, int, int], keep: tuple[int, int | None],
           wait_back: WaitBack) -> None:
    """The reset as one critical step: torque off (if on), reset, found at ``factory`` (ID, rate,
    protocol), then given ID ``keep[0]`` (and rate ``keep[1]``, None: the factory one)."""
    fid, fbps, fproto = factory
    with held():
        entry = JOURNAL.touch(servo.dxl_id, servo.model.name, ctx.bus.baudrate, "on" if torque else "off")
        if torque:
            servo.write("torque_enable", 0)
            entry.torque = "off (it was on)"
        reset = ctx.bus.execute(FactoryReset(servo.dxl_id, 0xFF, protocol=1))
        if not reset:
            raise StepFailed(f"{servo.who}: factory reset refused: {reset.why or 'no reply'}; nothing was reset "
                             f"(torque {entry.torque})")
        entry.done.append("factory reset (everything: Protocol 1.0 has no option) sent")
        entry.dxl_id, entry.baudrate = fid, fbps
        ctx.bus.set_baudrate(fbps)
        if wait_back(ctx.bus, fid, fproto) is None:
            raise StepFailed(f"{servo.who}: reset sent, but no servo answers at ID {fid}, {fbps} bps (its factory ID and "
                             f"rate, Protocol {fproto}.0) afterwards")
        entry.done[-1] = entry.done[-1].replace(" sent", " done")
        _keep(ctx, connect(ctx.bus, fid, fproto), entry, keep[0], keep[1])


def reset_all_then_keep(ctx: Context, servo: Servo, level: str, wait_back: WaitBack) -> None:
    """The Protocol 1.0 factory reset (see the module) of ``servo``, the bus at its rate."""
    here_id, here_bps = servo.dxl_id, ctx.bus.baudrate
    fid, fbps, fproto = factory_place(servo)
    keep_id, keep_bps = level in ("id", "id,baud"), level == "id,baud"
    final = (here_id if keep_id else fid, here_bps if keep_bps else fbps)
    guard.only_one(ctx, servo)
    _free(ctx, servo, (fid, fbps, fproto), "a Protocol 1.0 reset has no option: it would first answer at")
    if final != (fid, fbps):
        _free(ctx, servo, (*final, fproto), "after this reset it would answer at")
    torque = guard.torque_for(ctx, servo, "a factory reset")
    kept = {"all": "nothing", "id": "its ID (written back after the reset)",
            "id,baud": "its ID and baud rate (written back after the reset)"}[level]
    ctx.confirm(f"{servo.who}: factory reset of every item (Protocol 1.0: ID back to {fid}, baud rate to {fbps} bps), "
                f"keeping {kept}?" + (" Its torque is on: it goes off and stays off (the factory state)." if torque else ""))
    _reset(ctx, servo, torque, (fid, fbps, fproto), (final[0], final[1] if keep_bps else None), wait_back)
    said = f"{servo.who}: factory reset done; Protocol 1.0 resets everything: it came back as ID {fid} at {fbps} bps"
    if final != (fid, fbps):
        said += f", and was given back {'its ID and rate' if keep_bps else 'its ID'}"
    ctx.out.say(f"{said}; it answers at ID {final[0]}, {final[1]} bps" + (", torque off (the factory state)" if torque else ""))
    ctx.out.document.update(id=final[0], baudrate=final[1], kept=level, protocol=f"{fproto}.0",
                            reset_to={"id": fid, "baudrate": fbps})
