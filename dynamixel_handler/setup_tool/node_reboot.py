"""``reboot`` through a running handler node (``dynamixel/reboot_servos``): exactly the servos
named (``all``: every servo the node handles, from its ``dynamixel/manifest``) rebooted by the
node's loop, one a step, with the tool's rule: a reboot turns torque off, so a servo holding torque
is refused unless ``--torque-off`` (and asked about without ``--yes``); with it, the node turns its
torque back on after the reboot with the goal where the servo is, as on the bus. The node sets each
servo up again as after its own reboots (the ``servos`` block's RAM items and the profiles written
back). The output, ``--json`` and exit codes are those of ``reboot`` on the bus; a servo the node
does not handle is named in one line and the others rebooted (exit 1)."""
from __future__ import annotations

import argparse

from .context import confirm
from .errors import StepFailed
from .node_verbs import NodeContext
from .safety import reboot_consent
from .servo import Servo

__all__ = ["reboot_verb"]


def _holding(ctx: NodeContext, servos: list[Servo]) -> set[int]:
    """The IDs whose torque is on; TorqueOn (nothing rebooted) unless --torque-off, asked about
    without --yes (the words of ``reboot`` on the bus)."""
    with_torque = [s for s in servos if s.model.has("torque_enable")]
    now = ctx.read(with_torque, ["torque_enable"])
    holding = {s.dxl_id for s in with_torque if now[s.dxl_id]["torque_enable"]}
    reboot_consent(holding, len(servos), ctx.torque_off, lambda question: confirm(ctx.out, ctx.stdin, ctx.yes, question))
    return holding


def reboot_verb(ctx: NodeContext, args: argparse.Namespace) -> None:
    servos = ctx.find(args.id if args.id is not None else ctx.client.handled())
    if not servos:
        ctx.fail_if_missing("nothing was rebooted")
    holding = _holding(ctx, servos)
    res = ctx.client.reboot([s.dxl_id for s in servos], ctx.torque_off)
    failed, rebooted = [], []
    for dxl_id, torque, error in zip(res.id_list, res.torque_on, res.errors):
        servo = ctx.servos[int(dxl_id)]
        if error:
            failed.append(f"{servo.who}: reboot failed: {error}")
            continue
        rebooted.append(ctx.doc(servo, torque="on" if torque else "off"))
        ctx.out.say(f"{servo.who} rebooted and answers again" + (", torque back on (goal := present position)"
                                                                    if servo.dxl_id in holding and torque else ""))
    ctx.out.document.update(rebooted=[s["id"] for s in rebooted], servos=rebooted, failed=failed, missing=ctx.missing)
    if failed:
        raise StepFailed("; ".join(failed))
    ctx.fail_if_missing(f"{len(rebooted)} rebooted")
