"""The state topics: ``/dynamixel/states``, ``/dynamixel/debug`` and ``/dynamixel/state/*``, and
which of them one loop's reads fill (a message nobody subscribes to is not even built)."""
from __future__ import annotations

import threading
from typing import Any

import numpy as np
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

from ..core.handler import StepReport
from . import convert
from .cdr import _put_array, _put_message, _put_strings
from .lean import Patcher, TreePublisher, _patch_scalar

#: the messages of the state topics, which the handler may encode itself (``cdr.py``)
STATE_TYPES = (DxlStates, DynamixelDebug, DynamixelStatus, DynamixelPresent, DynamixelGoal, DynamixelGain,
               DynamixelLimit, DynamixelError, DynamixelExtra)
#: /dynamixel/state/<name> topics (not with ``no_use_command_line``)
STATE_TOPICS = (("status", DynamixelStatus), ("present", DynamixelPresent), ("goal", DynamixelGoal),
                ("gain", DynamixelGain), ("limit", DynamixelLimit), ("error", DynamixelError),
                ("extra", DynamixelExtra))
#: groups that fill the /dynamixel/state/<group> topic of the same name
SAME_NAME = ("status", "goal", "gain", "limit", "error")

#: per topic: the message as a nested dict, or its CDR bytes already (``Frame``)
Batch = list[tuple[TreePublisher, Any]]


class StatePublishers:
    def __init__(self, node: Node, raw: bool, per_group: bool, outdated_present: bool) -> None:
        self.outdated_present = outdated_present
        #: unit conversions and group messages kept from loop to loop (``convert.Cache``); one
        #: publishing thread at a time uses it (a late one of a restarted loop waits)
        self.cache = convert.Cache()
        self._lock = threading.Lock()
        self._frame: Frame | None = None
        #: (key, status) of a loop whose messages were built: its bytes make the next loop's frame
        self._pending: tuple[Any, Any] | None = None
        self._refused: Any = None  # the key of messages that a frame cannot be made of
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
            parts = convert.Parts(table, present_keys, self.outdated_present, self.cache)
            if not groups and self.states.raw:  # present values only: the bytes of the last such loop
                batch = self._from_frame(parts, present_keys, table, stamp)
                if batch is not None:
                    return batch
            else:
                self._frame = self._pending = None
            return self._messages(groups, present_keys, table, stamp, parts)

    def _from_frame(self, parts: convert.Parts, present_keys: set[str], table: Any, stamp: float) -> Batch | None:
        """This loop's bytes written over the last loop's (``Frame``), or None: build the messages
        (and make a frame of their bytes for the next loop)."""
        pubs = self._present_topics()
        status = parts.get("status") if self.debug in pubs else None
        key = (pubs, None if self.outdated_present else frozenset(present_keys), self.cache.epoch)
        frame = self._frame
        if frame is None or frame.key != key or frame.status is not status:
            frame = self._new_frame(pubs, key, status)
        if frame is not None:
            frame.key, frame.status = key, status
            batch = frame.run(table, stamp)
            if batch is not None:
                self._frame = frame
                return batch
        self._frame = None
        self._pending = (key, status) if key != self._refused else None
        return None

    def _new_frame(self, pubs: tuple[TreePublisher, ...], key: Any, status: Any) -> Frame | None:
        """A frame of the bytes the last loop left, if its messages were built for the same key."""
        pending, self._pending = self._pending, None
        if pending is None or pending[0] != key or pending[1] is not status:
            return None
        frame = Frame.of(pubs, status, self.cache)
        if frame is None:
            self._refused = key
        return frame

    def _present_topics(self) -> tuple[TreePublisher, ...]:
        """The topics a loop that read present values only fills (and somebody subscribes to)."""
        pubs = [p for p in (self.states, self.debug, self.by_group.get("present")) if p is not None]
        return tuple(p for p in pubs if p.wanted())

    def _messages(self, groups: set[str], present_keys: set[str], table: Any, stamp: float,
                  parts: convert.Parts) -> Batch:
        out: Batch = []
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


class Frame:
    """A loop that read present values only publishes the same messages as the last such loop but
    for the stamp and the arrays of the items read again. The frame notes, in the bytes each topic's
    ``Patcher`` holds from that loop, where each unit conversion went; a loop then writes the stamp
    and each conversion that is not the one already there, and publishes the bytes. It is made only
    when every array of those messages is accounted for: a conversion, the IDs, or part of the
    status message (the same object as then, else no frame is used)."""

    def __init__(self, pubs: tuple[TreePublisher, ...], cache: convert.Cache) -> None:
        self.pubs = pubs
        self.cache = cache
        self.leaves = [p.patcher._leaves for p in pubs]  # the recorded layouts this frame writes into
        #: item -> where its unit conversion is in the topics' bytes: (patcher, leaf)
        self.slots: dict[str, list[tuple[Patcher, list[Any]]]] = {}
        self.stamp: list[list[Any]] = []  # /dynamixel/states: sec and nanosec
        self.key: Any = None
        self.status: Any = None  # the status message the bytes hold (the very object)

    @classmethod
    def of(cls, pubs: tuple[TreePublisher, ...], status: Any, cache: convert.Cache) -> "Frame | None":
        frame = cls(pubs, cache)
        items = cache.items_of()
        fixed = {id(cache.id_list), id(None)}
        fixed.update(id(v) for v in (status or {}).values())
        for pub, leaves in zip(pubs, frame.leaves):
            if pub.patcher._buf is None:
                return None
            if pub.codec.msg_class is DxlStates:
                if pub.codec.fields[0][0] != "stamp" or len(leaves) < 3 or leaves[0][0]:
                    return None
                frame.stamp = leaves[1:3]
            for leaf in leaves[3:] if pub.codec.msg_class is DxlStates else leaves:
                if not frame._note(pub, leaf, items, fixed):
                    return None
        return frame

    def _note(self, pub: TreePublisher, leaf: list[Any], items: dict[int, str], fixed: set[int]) -> bool:
        """Whether ``leaf`` is accounted for (a part given or not, or an array as above)."""
        value, _, put, detail = leaf
        if put is _put_message or id(value) in fixed:
            return True
        if put is _put_array and detail[0] == "f8" and id(value) in items and value.dtype == np.float64:
            self.slots.setdefault(items[id(value)], []).append((pub.patcher, leaf))
            return True
        return put is _put_strings and pub.codec.msg_class is DynamixelDebug  # the status part's modes

    def run(self, table: Any, stamp: float) -> Batch | None:
        """This loop's bytes per topic, or None (the layouts changed: build the messages)."""
        locks = [p.patcher._lock for p in self.pubs]
        for lock in locks:  # a late publishing thread of a restarted loop may be encoding
            lock.acquire()
        try:
            if any(p.patcher._leaves is not leaves for p, leaves in zip(self.pubs, self.leaves)):
                return None
            if not self._write(table, stamp):
                return None
            return [(pub, bytes(_buffer(pub.patcher))) for pub in self.pubs]
        finally:
            for lock in locks:
                lock.release()

    def _write(self, table: Any, stamp: float) -> bool:
        units = self.cache.units
        for item, where in self.slots.items():
            value = units(table, item)
            data = None
            for patcher, leaf in where:
                if value is not leaf[0]:
                    if value.size != leaf[0].size or value.dtype != np.float64:
                        return False
                    if data is None:
                        data = value.astype("<f8", copy=False).tobytes()
                    _buffer(patcher)[leaf[1] - len(data):leaf[1]] = data
                    leaf[0] = value
        if self.stamp:
            buf = _buffer(self.pubs[0].patcher)
            for leaf, v in zip(self.stamp, convert._stamp(stamp)):
                _patch_scalar(buf, v, leaf, leaf[3])
        return True


def _buffer(patcher: Patcher) -> bytearray:
    assert patcher._buf is not None  # a frame is made of patchers that hold bytes
    return patcher._buf
