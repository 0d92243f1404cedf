"""Command subscriptions: message (as ``cdr.Codec``'s nested dict) -> (id_list, {field: values})
-> Commander.

Handlers only unpack and check array lengths; the Commander does the rest in the loop thread.
A handler never raises: whatever goes wrong is logged with the topic's name. Messages arrive
through ``intake.CommandIntake`` (taken by the loop thread at the start of each step).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsP,
    DxlCommandsPro,
    DxlCommandsX,
    DynamixelControlPCurrent,
    DynamixelControlPExtendedPosition,
    DynamixelControlPPosition,
    DynamixelControlPPwm,
    DynamixelControlProCurrent,
    DynamixelControlProExtendedPosition,
    DynamixelControlProPosition,
    DynamixelControlProVelocity,
    DynamixelControlPVelocity,
    DynamixelControlXCurrent,
    DynamixelControlXCurrentBasePosition,
    DynamixelControlXExtendedPosition,
    DynamixelControlXPosition,
    DynamixelControlXPwm,
    DynamixelControlXVelocity,
    DynamixelExtra,
    DynamixelGain,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from ..commands import Commander, take_fields
from ..commands.command_types import GROUPS
from ..control_table import PRO, P, ServoFamily, X, family_named
from ..logs import cut
from .intake import CommandIntake

#: most IDs a command can name (0..252): a longer id_list is refused as a whole, before any work
#: that grows with its length
MAX_IDS = 253

CONTROL_TYPES: dict[ServoFamily, dict[str, type]] = {
    X: {"pwm_control": DynamixelControlXPwm, "current_control": DynamixelControlXCurrent,
          "velocity_control": DynamixelControlXVelocity, "position_control": DynamixelControlXPosition,
          "extended_position_control": DynamixelControlXExtendedPosition,
          "current_base_position_control": DynamixelControlXCurrentBasePosition},
    P: {"pwm_control": DynamixelControlPPwm, "current_control": DynamixelControlPCurrent,
          "velocity_control": DynamixelControlPVelocity, "position_control": DynamixelControlPPosition,
          "extended_position_control": DynamixelControlPExtendedPosition},
    PRO: {"current_control": DynamixelControlProCurrent, "velocity_control": DynamixelControlProVelocity,
            "position_control": DynamixelControlProPosition,
            "extended_position_control": DynamixelControlProExtendedPosition},
}
COMMANDS_TYPES: dict[ServoFamily, type] = {X: DxlCommandsX, P: DxlCommandsP, PRO: DxlCommandsPro}
GROUP_TYPES = {"status": DynamixelStatus, "goal": DynamixelGoal, "gain": DynamixelGain, "limit": DynamixelLimit,
               "extra": DynamixelExtra}
#: the parts of a bundle (commands/x, ...) after its control parts, in the order they apply
BUNDLE_GROUPS = ("status", "goal", "gain", "limit", "extra")
#: every message type a command topic carries
COMMAND_TYPES = (DxlCommandsAll, DynamixelShortcut, *COMMANDS_TYPES.values(),
                 *(t for types in CONTROL_TYPES.values() for t in types.values()), *GROUP_TYPES.values())


def unpack(msg: dict) -> tuple[list[int], dict[str, list]]:
    """id_list and every other array of a Dynamixel* message; nested messages flatten to 'a.b'."""
    fields: dict[str, list] = {}

    def walk(m: dict, prefix: str) -> None:
        for name, value in m.items():
            if isinstance(value, dict):
                walk(value, f"{prefix}{name}.")
            elif name != "id_list" or prefix:
                fields[prefix + name] = value
    walk(msg, "")
    ids = msg["id_list"]
    return ids.tolist() if isinstance(ids, np.ndarray) and ids.dtype.kind in "iu" else [int(i) for i in ids], fields


class CommandTopics:
    def __init__(self, intake: CommandIntake, commander: Commander, series: tuple[str, ...], command_line: bool) -> None:
        self.commander = commander
        self.log = intake.log

        def sub(typ, topic, callback, depth):
            intake.subscribe(typ, topic, callback, depth)
        # a family driven through another's topics (XL-320: the X ones) subscribes those, once
        # a family without series topics (Y) is driven through the series-independent ones only
        families = [f for f in dict.fromkeys(family_named(s).command_family for s in series) if f is not None]
        for f in families:
            sub(COMMANDS_TYPES[f], f"dynamixel/commands/{f.suffix}",
                self._guard(f"commands/{f.suffix}", lambda m, f=f: self._bundle(f, m)), 10)
        sub(DxlCommandsAll, "dynamixel/commands/all", self._guard("commands/all", lambda m: self._bundle(None, m)), 10)
        sub(DynamixelShortcut, "dynamixel/shortcut", self._guard("shortcut", self._shortcut), 10)
        if not command_line:
            return
        for f in families:
            for control, typ in CONTROL_TYPES[f].items():
                topic = f"command/{f.suffix}/{control}"
                sub(typ, f"dynamixel/{topic}", self._guard(topic, lambda m, f=f, c=control, t=topic: self._control(f, c, m, t)), 10)
        for group, typ in GROUP_TYPES.items():
            topic = f"command/{group}"
            sub(typ, f"dynamixel/{topic}", self._guard(topic, lambda m, g=group, t=topic: self._group(g, m, t)), 10)

    def _guard(self, topic: str, callback: Callable) -> Callable:
        def run(msg) -> None:
            try:
                callback(msg)
            except Exception as exc:  # a bad message must never take the node down
                self.commander.throttle(f"/dynamixel/{topic}: command dropped: {type(exc).__name__}: {cut(exc)}",
                                        key=f"{topic} {type(exc).__name__}")
        return run

    def _fields(self, what: str, msg: dict) -> tuple[list[int], dict[str, list]]:
        count = len(msg["id_list"])
        if count == 0:  # nothing to do; most parts of a bundle are empty
            return [], {}
        if count > MAX_IDS:
            self.commander.warn(f"{what}: id_list has {count} IDs, more than the {MAX_IDS} a bus can have: "
                                "message refused")
            return [], {}
        ids, fields = unpack(msg)
        return ids, take_fields(what, ids, fields, self.commander.warn)

    def _control(self, series: ServoFamily, control: str, msg, what: str) -> None:
        # id_list alone switches the servos to the control's mode (and writes no goal)
        ids, fields = self._fields(what, msg)
        if ids:
            self.commander.control(series, control, ids, fields)

    def _group(self, group: str, msg, what: str) -> None:
        ids, fields = self._fields(what, msg)
        if ids and fields:
            self.commander.submit(GROUPS[group](list(ids), fields, what))

    def _bundle(self, series: ServoFamily | None, msg) -> None:
        prefix = "commands/" + (series.suffix if series is not None else "all")
        skip = self.commander.paths.skip_empty  # False: every part through its handler (comparisons)
        if series is not None:
            for control in CONTROL_TYPES[series]:
                part = msg[control]
                if not skip or len(part["id_list"]):  # most parts of a bundle are empty: nothing to do
                    self._control(series, control, part, f"{prefix}.{control}")
        for group in BUNDLE_GROUPS:
            if group in msg:
                part = msg[group]
                if not skip or len(part["id_list"]):
                    self._group(group, part, f"{prefix}.{group}")

    def _shortcut(self, msg: dict) -> None:
        if len(msg["id_list"]) > MAX_IDS:
            self.commander.warn(f"shortcut: id_list has {len(msg['id_list'])} IDs, more than the {MAX_IDS} a bus "
                                "can have: message refused")
            return
        self.commander.shortcut(msg["command"], [int(i) for i in msg["id_list"]])
