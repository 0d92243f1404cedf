"""The state topics: ``/dynamixel/states``, ``/dynamixel/debug`` and ``/dynamixel/state/*``, and
which of them one loop's reads fill (a message nobody subscribes to is not even built)."""
from __future__ import annotations

import threading
from typing import Any

from rclpy.node import Node

from dynamixel_handler_msgs.msg import (
    DxlStates,
    DynamixelDebug,
    DynamixelError,
    DynamixelExtra,
    DynamixelGain,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelPresent,
    DynamixelStatus,
)

from ..loop import StepReport
from . import convert
from .lean import TreePublisher

#: the messages of the state topics, which the handler may encode itself (``cdr.py``)
STATE_TYPES = (DxlStates, DynamixelDebug, DynamixelStatus, DynamixelPresent, DynamixelGoal, DynamixelGain,
               DynamixelLimit, DynamixelError, DynamixelExtra)
#: /dynamixel/state/<name> topics (not with ``no_use_command_line``)
STATE_TOPICS = (("status", DynamixelStatus), ("present", DynamixelPresent), ("goal", DynamixelGoal),
                ("gain", DynamixelGain), ("limit", DynamixelLimit), ("error", DynamixelError),
                ("extra", DynamixelExtra))
#: groups that fill the /dynamixel/state/<group> topic of the same name
SAME_NAME = ("status", "goal", "gain", "limit", "error")

Batch = list[tuple[TreePublisher, dict[str, Any]]]


class StatePublishers:
    def __init__(self, node: Node, raw: bool, per_group: bool, outdated_present: bool) -> None:
        self.outdated_present = outdated_present
        #: unit conversions and group messages kept from loop to loop (``convert.Cache``); one
        #: publishing thread at a time uses it (a late one of a restarted loop waits)
        self.cache = convert.Cache()
        self._lock = threading.Lock()
        self.states = TreePublisher(node, DxlStates, "dynamixel/states", 10, raw)
        self.debug = TreePublisher(node, DynamixelDebug, "dynamixel/debug", 10, raw)
        self.by_group: dict[str, TreePublisher] = {}
        if per_group:
            for name, typ in STATE_TOPICS:
                self.by_group[name] = TreePublisher(node, typ, f"dynamixel/state/{name}", 10, raw)

    def messages(self, report: StepReport, table: Any, stamp: float) -> Batch:
        """What this loop read, per topic. ``stamp``: the time of the reads on the node's clock."""
        groups, present_keys = report.groups, report.present
        if not (groups or present_keys):
            return []
        with self._lock:
            return self._messages(groups, present_keys, table, stamp)

    def _messages(self, groups: set[str], present_keys: set[str], table: Any, stamp: float) -> Batch:
        out: Batch = []
        parts = convert.Parts(table, present_keys, self.outdated_present, self.cache)
        if self.states.wanted():
            out.append((self.states, convert.states(table, stamp, groups, present_keys, parts=parts,
                                                    outdated_present=self.outdated_present)))
        if (present_keys or "status" in groups) and self.debug.wanted():
            out.append((self.debug, convert.debug(table, parts.get("status"), parts.units)))
        for name in self._due(groups, present_keys) if self.by_group else ():
            if self.by_group[name].wanted():
                out.append((self.by_group[name], parts.get(name)))
        return out

    @staticmethod
    def _due(groups: set[str], present_keys: set[str]) -> list[str]:
        """The /dynamixel/state/* topics this loop's reads fill."""
        due = [name for name in SAME_NAME if name in groups]
        if present_keys:
            due.append("present")
        if groups & {"extra_dynamic", "extra_static"}:
            due.append("extra")
        return due
