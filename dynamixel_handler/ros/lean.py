"""Publishers and subscriptions without rclpy's default QoS-event handlers, and publishers of
nested-dict messages (``cdr.Codec``) as raw CDR bytes.

By default every publisher and subscription brings two event handlers (incompatible QoS, incompatible
type). Each is a waitable the executor rebuilds into its wait set on every spin; with the handler's
~40 topics they cost more CPU per received command than the command itself.
"""
from __future__ import annotations

import struct
import threading
import time
from typing import Any, Callable, Mapping

import numpy as np
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node

from .cdr import _LE, _STRUCT, Codec, Unsupported, _put_array, _put_message, _put_one_string, _put_scalar, _put_strings
from .fastpath import RAW_ENV


def lean_publisher(node: Node, typ, topic: str, depth=10):
    return node.create_publisher(typ, topic, depth, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))


def lean_subscription(node: Node, typ, topic: str, callback: Callable, depth=10, raw: bool = False):
    return node.create_subscription(typ, topic, callback, depth, raw=raw,
                                    event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))


#: seconds between two subscription counts of a state topic (``TreePublisher.wanted``)
RECHECK_S = 0.1


class TreePublisher:
    """Publishes ``cdr.Codec`` values (nested dicts of numpy arrays): encoded to CDR bytes when
    ``raw``, else turned into an rclpy message object."""

    def __init__(self, node: Node, typ, topic: str, depth: int, raw: bool) -> None:
        self.publisher = lean_publisher(node, typ, topic, depth)
        self.codec = Codec.of(typ)
        self.raw = raw
        self.patcher = Patcher(self.codec)
        self._wanted = False
        self._recheck = 0.0  # time.monotonic() of the next subscription count

    def wanted(self) -> bool:
        """Somebody subscribes (a message nobody receives is not even built). The middleware is
        asked at most every ``RECHECK_S``: a new subscriber gets messages that much later at most."""
        now = time.monotonic()
        if now >= self._recheck:
            self._wanted = self.publisher.get_subscription_count() > 0
            self._recheck = now + RECHECK_S
        return self._wanted

    def publish(self, value: Any) -> None:
        """``value``: a nested dict, or (raw only) its CDR bytes already."""
        if type(value) is bytes:
            self.publisher.publish(value)
        else:
            self.publisher.publish(self.patcher.encode(value) if self.raw else self.codec.to_message(value))


class _Changed(Exception):
    """The value's layout differs from the last one (a sequence's length, a string, a part given or not)."""


class Patcher:
    """``Codec.encode`` of successive values of one type, as the bytes of the previous value with
    what changed written over them. A state message keeps its layout from loop to loop (the same
    servos, the same groups) and most of its arrays too (``convert.Cache``), so only the arrays read
    again and the stamp are written. The layout is checked on every value: a sequence of another
    length, another string, a part given or left out, and the whole value is encoded again.

    An array the last value held is skipped when it is the very same read-only numpy array (it
    cannot have changed); any other array is written again."""

    def __init__(self, codec: Codec) -> None:
        self.codec = codec
        self._buf: bytearray | None = None
        #: per field in encoding order: [value, end offset, encoder, detail], nested parts' fields inline
        self._leaves: list[list[Any]] = []
        self._lock = threading.Lock()

    def encode(self, value: Mapping[str, Any]) -> bytes:
        with self._lock:  # one thread at a time (a late publishing thread of a restarted loop waits)
            return self._encode(value)

    def _encode(self, value: Mapping[str, Any]) -> bytes:
        if self._buf is not None:
            try:
                _patch(self.codec, self._buf, value, self._leaves, 0)
                return bytes(self._buf)
            except _Changed:
                pass
            except Exception:  # a value the encoder refuses: start afresh next time
                self._buf = None
                raise
        out = bytearray(b"\x00\x01\x00\x00")
        leaves: list[list[Any]] = []
        _record(self.codec, out, value, leaves)
        out += b"\x00" * (-len(out) % 4)
        self._buf, self._leaves = out, leaves
        return bytes(out)


def _record(codec: Codec, out: bytearray, value: Mapping[str, Any], leaves: list[list[Any]]) -> None:
    """``Codec._encode_into``, noting each field's value and where its bytes end."""
    for name, put, detail in codec._puts:
        v = value.get(name)
        if put is _put_message:
            leaves.append([v is None, 0, put, detail])
            if v is None:
                detail._encode_empty(out)
            else:
                _record(detail, out, v, leaves)
            continue
        if put is _put_strings:
            v = list(v) if v is not None else []
        elif put is _put_array and v is not None and type(v) is not np.ndarray:
            v = np.asarray(v)
        put(out, v, detail)
        leaves.append([v, len(out), put, detail])


def _patch(codec: Codec, buf: bytearray, value: Mapping[str, Any], leaves: list[list[Any]], i: int) -> int:
    """Write ``value`` over the bytes ``_record`` noted in ``leaves`` from ``i``; the next index."""
    get = value.get
    for name, put, detail in codec._puts:
        v = get(name)
        leaf = leaves[i]
        i += 1
        if put is _put_array:
            if v is not leaf[0] or (v is not None and v.flags.writeable):  # else: the same read-only array
                _patch_array(buf, v, leaf, detail)
        elif put is _put_message:
            if leaf[0] != (v is None):
                raise _Changed
            if v is not None:
                i = _patch(detail, buf, v, leaves, i)
        else:
            _PATCH[put](buf, v, leaf, detail)
    return i


def _patch_array(buf: bytearray, v: Any, leaf: list[Any], detail: tuple[str, int]) -> None:
    old = leaf[0]
    arr = v if type(v) is np.ndarray or v is None else np.asarray(v)
    n = 0 if arr is None else arr.size
    if n != (0 if old is None else old.size):
        raise _Changed
    if arr is not None and n:
        end = leaf[1]
        data = arr.astype(_LE[detail[0]], copy=False).tobytes()
        buf[end - len(data):end] = data
    leaf[0] = arr


def _patch_scalar(buf: bytearray, v: Any, leaf: list[Any], detail: tuple[str, int]) -> None:
    if v == leaf[0] and type(v) is type(leaf[0]):
        return
    code, size = detail
    start = leaf[1] - size
    buf[start:start + size] = bytes(size)
    if code == "?":
        buf[start] = 1 if v else 0
    elif v is not None:
        struct.pack_into("<" + _STRUCT[code], buf, start, v)
    leaf[0] = v


def _patch_strings(buf: bytearray, v: Any, leaf: list[Any], detail: None) -> None:
    if (list(v) if v is not None else []) != leaf[0]:
        raise _Changed


def _patch_string(buf: bytearray, v: Any, leaf: list[Any], detail: None) -> None:
    if v != leaf[0]:
        raise _Changed


#: field encoder -> what writes a new value of that field over the old one (or raises ``_Changed``)
_PATCH: dict[Any, Callable[[bytearray, Any, list[Any], Any], None]] = {
    _put_scalar: _patch_scalar, _put_strings: _patch_strings,
    _put_one_string: _patch_string}


__all__ = ["RAW_ENV", "Patcher", "TreePublisher", "Unsupported", "lean_publisher", "lean_subscription"]
