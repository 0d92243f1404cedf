"""Command topics taken by the loop thread itself, at the start of each loop step.

Through an executor every command message costs a wake-up, a wait set rebuilt in Python over every
entity of the node, a hand-over to a worker thread and rclpy's conversion of the whole message into
Python objects, all fighting the loop thread for the interpreter lock. The loop only applies
commands at the start of a step anyway, so it takes them itself, right before it applies them:
as raw CDR bytes (decoded by ``cdr.Codec`` straight into numpy arrays) when the middleware agrees
with ``cdr.py``, else as rclpy messages. Messages taken in one step, from any of the command topics,
are handled in the order they were published (source timestamp).

The subscriptions are ordinary subscriptions of the node (``ros2 node info`` lists them, QoS as
before) that are kept out of the executor's sight (``fastpath.detach``). Without the detached
intake (``fastpath.FastPaths``) they are left to the executor and their callbacks do the same work.
"""
from __future__ import annotations

import threading
import time
from typing import Any, Callable

from rclpy.node import Node

from . import fastpath
from .cdr import Codec, DecodeError
from .lean import lean_subscription

Handler = Callable[[dict[str, Any]], None]
#: sees a message as taken, before it is decoded: False drops it
Screen = Callable[[Any], bool]
#: a command subscription: (subscription, codec, handler, topic, taken raw, screen)
Entry = tuple[Any, Codec, Handler, str, bool, "Screen | None"]


class CommandIntake:
    def __init__(self, node: Node, raw: bool, detached: bool) -> None:
        self.node = node
        self.raw = raw
        self.log = node.get_logger()
        self.detached = detached
        self._entries: list[Entry] = []
        self._takers: list[tuple[Callable[[], Any], Entry]] = []
        self._lock = threading.Lock()  # poll() and close() may come from different threads
        self.taken = 0
        self.undecodable = 0
        self._waiter = fastpath.Waiter(node)

    def subscribe(self, typ, topic: str, handler: Handler, depth: int = 10, raw: bool | None = None,
                  screen: Screen | None = None) -> None:
        """``handler`` gets the message as a nested dict (``cdr.Codec.decode``'s form). ``raw``: take
        this topic as CDR bytes (default: as the intake does; False where the codec's self check
        failed for ``typ``). ``screen`` sees the message as taken (bytes when raw) before it is
        decoded and returns False to drop it (it says why), e.g. one too large to decode."""
        codec = Codec.of(typ)
        raw = self.raw if raw is None else raw and self.raw
        if not self.detached:
            def callback(msg, codec=codec, handler=handler, topic=topic, raw=raw, screen=screen) -> None:
                if screen is not None and not screen(msg):
                    return
                value = self._value(codec, msg, topic, raw)
                if value is not None:
                    handler(value)
            lean_subscription(self.node, typ, topic, callback, depth, raw=raw)
            return
        sub = lean_subscription(self.node, typ, topic, _never_called, depth, raw=raw)
        fastpath.detach(self.node, sub)  # the executor does not see it; poll() takes it
        self._entries.append((sub, codec, handler, topic, raw, screen))
        self._takers.append((fastpath.taker(sub, raw), self._entries[-1]))

    def poll(self) -> int:
        """Take every waiting message of every command topic and hand them over in publish order.
        Returns the number of messages handled."""
        batch: list[tuple[int, int, Any, Entry]] = []
        with self._lock:
            for take, entry in self._takers:
                while True:
                    try:  # close() destroys under the same lock, so no handle guard is needed
                        got = take()
                    except Exception as exc:  # a destroyed handle or a middleware error: never fatal
                        self.log.error(f"{entry[3]}: take failed: {type(exc).__name__}: {exc}")
                        break
                    if got is None:
                        break
                    batch.append((got[1].get("source_timestamp", 0), len(batch), got[0], entry))
        if len(batch) > 1:
            batch.sort(key=lambda b: (b[0], b[1]))
        for _, _, msg, (_, codec, handler, topic, raw, screen) in batch:
            if screen is not None and not screen(msg):
                continue
            value = self._value(codec, msg, topic, raw)
            if value is not None:
                handler(value)
        self.taken += len(batch)
        return len(batch)

    def discard(self) -> int:
        """Take every waiting message of every command topic and drop it, undecoded (a lifecycle
        node that is not active). Returns the number of messages dropped."""
        count = 0
        with self._lock:
            for take, _ in self._takers:
                while True:
                    try:
                        got = take()
                    except Exception:  # a destroyed handle: nothing more to take
                        break
                    if got is None:
                        break
                    count += 1
        return count

    def wait(self, timeout_s: float) -> bool:
        """Block, without holding the interpreter lock, until a message waits on a command topic or
        ``timeout_s`` passes; True if one waits. Without detached subscriptions: sleeps, False."""
        if not self.detached or not self._entries:
            time.sleep(max(0.0, timeout_s))
            return False
        # close() destroys the subscriptions under the same lock, so their handles stay valid here
        with self._lock:
            return self._waiter.wait([entry[0] for entry in self._entries], timeout_s)

    def _value(self, codec: Codec, msg, topic: str, raw: bool) -> dict[str, Any] | None:
        if not raw:
            return codec.from_message(msg)
        try:
            return codec.decode(msg)
        except DecodeError as exc:
            # e.g. a writer using XCDR2: let rclpy read it
            try:
                from rclpy.serialization import deserialize_message
                return codec.from_message(deserialize_message(msg, codec.msg_class))
            except Exception:
                self.undecodable += 1
                self.log.error(f"{topic}: message dropped: cannot decode it ({exc})")
                return None

    def close(self) -> None:
        with self._lock:
            self._waiter.close()
            for sub, *_ in self._entries:
                try:
                    sub.destroy()
                except Exception:  # already gone with the node
                    pass
            self._entries.clear()
            self._takers.clear()


def _never_called(msg) -> None:  # pragma: no cover - detached subscriptions have no executor
    raise AssertionError("a detached command subscription was run by an executor")
