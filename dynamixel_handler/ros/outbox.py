"""Publishing on a thread of its own, so a loop's messages are built and go out while the next
loop's instruction is on the wire (the loop thread then waits in ``select`` with the interpreter
lock released). The loop thread hands over a ``Loop`` (what the loop read, a snapshot of the servo
table, the stamp): a value, not a call; the builder given at construction turns it into messages
here, where encoding them and the middleware's write happen too, in loop order.
"""
from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from .lean import TreePublisher

Batch = Sequence[tuple[TreePublisher, Any]]  # a message as a nested dict or as CDR bytes


@dataclass(frozen=True)
class Loop:
    """One loop's publishing, as the loop thread hands it over."""
    report: Any     #: the loop's ``StepReport``
    table: Any      #: a snapshot of the servo table after the loop
    stamp: float    #: the states' stamp [s]


Build = Callable[[Loop], Batch]  # one loop's messages

#: loops' worth of messages held when the publishing thread falls behind; older ones are dropped
DEPTH = 8
#: seconds between two warnings about dropped messages
WARN_EVERY_S = 10.0


class Outbox:
    def __init__(self, log, build: Build, depth: int = DEPTH) -> None:
        self.log = log
        self._build = build
        self._queue: collections.deque[Loop] = collections.deque()
        self._depth = depth
        self._cond = threading.Condition()
        self._closing = False
        self.sent = 0
        self.dropped = 0
        self._dropped_reported = 0
        self._next_warning = 0.0
        self._thread = threading.Thread(target=self._run, name="dynamixel_publish", daemon=True)
        self._thread.start()

    def put(self, loop: Loop) -> None:
        with self._cond:
            if len(self._queue) >= self._depth:
                self._queue.popleft()
                self.dropped += 1
            self._queue.append(loop)
            self._cond.notify()
        if self.dropped != self._dropped_reported and time.monotonic() >= self._next_warning:
            self._next_warning = time.monotonic() + WARN_EVERY_S
            self.log.warning(f"publishing falls behind the loop: {self.dropped - self._dropped_reported} loops' "
                             f"messages dropped (the oldest first; {self.dropped} in all)")
            self._dropped_reported = self.dropped

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closing:
                    self._cond.wait()
                if not self._queue:
                    return
                loop = self._queue.popleft()
            try:
                batch = self._build(loop)
            except Exception as exc:  # a loop whose messages cannot be built: say so, go on
                self.log.error(f"building this loop's messages: {type(exc).__name__}: {exc}")
                continue
            for publisher, value in batch:
                try:
                    publisher.publish(value)
                    self.sent += 1
                except Exception as exc:  # one bad message must not stop publishing
                    self.log.error(f"publishing {publisher.publisher.topic_name}: {type(exc).__name__}: {exc}")

    def close(self, timeout: float = 2.0) -> None:
        """Publish what is queued, then stop the thread."""
        with self._cond:
            self._closing = True
            self._cond.notify()
        self._thread.join(timeout)
