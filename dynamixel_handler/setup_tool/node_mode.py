"""``set-mode`` through a running handler node: the node's own mode change (a status command's
``mode`` on ``dynamixel/commands/all``: torque off, Operating Mode, the other modes' goals and the
profiles written back, torque on the safe way), with the tool's rules: a servo holding torque only
with ``--torque-off``, the EEPROM write asked unless ``--yes``; then the mode read back through
``dynamixel/get_items``. A Protocol 1.0 model (its mode is its Angle Limits) is refused here."""
from __future__ import annotations

import argparse
import time

from .checks import cut
from .context import confirm
from .errors import BadArguments, StepFailed
from .guard import torque_done, torque_question
from .items import show_value
from .node_verbs import NodeContext
from .safety import refuse_torque
from .servo import Servo

__all__ = ["set_mode_verb", "wait_modes"]

#: how long the node is given to switch (its mode_change_interval_sec, 1 s by default, and retries) [s]
SWITCH_S = 8.0


def _mode_of(servo: Servo, text: str) -> int:
    """The register value of mode ``text`` (a name, or a register value of a mode the model takes)."""
    if servo.modes_by_limits:
        raise BadArguments(f"{servo.who}: a Protocol 1.0 model's mode (its Angle Limits) is not set through the "
                           "running node: stop the node first, then set-mode")
    modes = servo.model.mode_values
    if text in modes:
        return modes[text]
    if text.isdigit() and int(text) in modes.values():
        return int(text)
    raise BadArguments(f"{servo.who}: {servo.model.name} has no operating mode '{cut(text)}' that the node switches to "
                       f"(one of {', '.join(modes)})")


def set_mode_verb(ctx: NodeContext, args: argparse.Namespace) -> None:
    servos = ctx.find(args.id)
    text = str(args.mode).strip().lower()
    target = {s.dxl_id: _mode_of(s, text) for s in servos}
    now = ctx.read(servos, ["operating_mode", "torque_enable"])
    changing = [s for s in servos if now[s.dxl_id]["operating_mode"] != target[s.dxl_id]]
    torque = {s.dxl_id for s in changing if now[s.dxl_id]["torque_enable"] == 1}
    if changing:
        _switch(ctx, changing, changing[0].model.mode_name(target[changing[0].dxl_id]) or text, torque)
    _report(ctx, args, servos, changing, target, now, torque, wait_modes(ctx, changing, target))


def _switch(ctx: NodeContext, changing: list[Servo], name: str, torque: set[int]) -> None:
    """The torque rule, the question, then the node asked to switch ``changing`` to mode ``name``."""
    for s in changing:
        if s.dxl_id in torque and not ctx.torque_off:
            raise refuse_torque(s, s.item("operating_mode"))
    confirm(ctx.out, ctx.stdin, ctx.yes, f"write operating_mode (EEPROM) of ID "
            f"{', '.join(str(s.dxl_id) for s in changing)} through the node?" + torque_question(bool(torque)))
    ctx.client.switch_modes([s.dxl_id for s in changing], name)


def _report(ctx: NodeContext, args: argparse.Namespace, servos: list[Servo], changing: list[Servo],
            target: dict[int, int], now: dict[int, dict[str, int]], torque: set[int], after: dict[int, int]) -> None:
    """Each servo's result in a line, the JSON document; StepFailed for one that did not switch."""
    docs, wrong = [], []
    for s in servos:
        item = s.item("operating_mode")
        shown, was = show_value(s.model, item, target[s.dxl_id]), now[s.dxl_id]["operating_mode"]
        if s not in changing:
            ctx.out.say(f"{s.who} operating_mode is already {shown}: nothing written")
        elif after.get(s.dxl_id) != target[s.dxl_id]:
            wrong.append(f"{s.who}: operating_mode reads {show_value(s.model, item, after.get(s.dxl_id, was))} "
                         f"{SWITCH_S:g} s after the node was asked for {shown} (its log says why)")
        else:
            ctx.out.say(f"{s.who} operating_mode = {shown} (was {show_value(s.model, item, was)}), read back"
                        + torque_done(s.dxl_id in torque))
        docs.append(ctx.doc(s, item=item.name, raw=target[s.dxl_id], before=was, written=s in changing))
    ctx.out.document.update(docs[0] if len(args.id) == 1 and docs else {"servos": docs, "missing": ctx.missing})
    if wrong:
        raise StepFailed("; ".join(wrong))
    ctx.fail_if_missing("the others were switched")


def wait_modes(ctx: NodeContext, changing: list[Servo], target: dict[int, int]) -> dict[int, int]:
    """The modes of ``changing`` once all read as asked, or as they read after SWITCH_S."""
    end = time.monotonic() + SWITCH_S
    got: dict[int, int] = {}
    while changing:
        got = {i: v["operating_mode"] for i, v in ctx.read(changing, ["operating_mode"]).items()}
        if all(got[s.dxl_id] == target[s.dxl_id] for s in changing) or time.monotonic() > end:
            break
        time.sleep(0.1)
    return got
