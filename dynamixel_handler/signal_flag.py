"""A signal handler that only sets a flag, for the node's process and the virtual bus's command line.

Python runs a signal handler on the main thread between two of its steps, wherever that thread is:
also inside ``threading.Event.wait`` or ``Event.set`` at the moment the Event's own (non-reentrant)
lock is held. A handler that calls ``Event.set()`` (or anything else that takes a lock) then waits
for that lock forever, and the process ignores every later signal: a node did not stop within 15 s
of its SIGINT, its loop running on. So the handler takes no lock and calls nothing; the main thread
looks at the flag in short sleeps (``time.sleep`` is cut short by the signal and the flag is seen at
once) and does the rest itself.
"""
from __future__ import annotations

import signal
import time
from typing import Any, Callable

#: how often (s) a waiting main thread looks at the flag besides being woken by the signal itself
POLL_S = 0.05


class SignalFlag:
    """Set by the first of the signals it is installed for; never cleared."""

    def __init__(self) -> None:
        self.signum: int | None = None

    def __call__(self, signum: int, _frame: Any) -> None:
        if self.signum is None:  # a plain attribute: no lock, no call
            self.signum = signum

    @property
    def came(self) -> bool:
        return self.signum is not None

    def install(self, *signums: int) -> None:
        for signum in signums:
            signal.signal(signum, self)

    def wait(self, done: Callable[[], bool] = lambda: False, timeout: float | None = None) -> bool:
        """Sleep until a signal came or ``done()`` is true (or ``timeout`` s passed); whether a
        signal came. Main thread only (elsewhere a signal does not cut the sleep short)."""
        end = None if timeout is None else time.monotonic() + timeout
        while not (self.came or done()):
            left = POLL_S if end is None else min(POLL_S, end - time.monotonic())
            if left <= 0:
                break
            time.sleep(left)
        return self.came
