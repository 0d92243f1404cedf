"""The loop's own lines that can repeat, at most one a second per cause and servo (``logs.Throttle``),
and the answering state of each servo (ping false / answers again), whose last line always tells
the state the servo is in."""
from __future__ import annotations

import logging
import time
from typing import Any, Callable

from ..logs import Throttle

#: least time between two lines of one cause and servo [s]
LINE_INTERVAL_S = 1.0


class LogLimits:
    """``limited(level, msg, key)``: ``msg`` at ``level`` unless ``key`` was logged less than a
    second ago; the next line of that key says how many were left out. ``emit(level, msg)`` writes
    a line (a part passes one that looks its logger up at each line: the logger may be replaced)."""

    def __init__(self, emit: Callable[[int, str], None]) -> None:
        self._emit = emit
        self._throttles: dict[int, Throttle] = {}

    def __call__(self, level: int, msg: str, key: str) -> bool:
        throttle = self._throttles.get(level)
        if throttle is None:
            throttle = self._throttles[level] = Throttle(lambda m: self._emit(level, m), LINE_INTERVAL_S)
        return throttle(msg, key)


class PingLog:
    """"ID n: no response (ping false)" and "ID n: answers again", at most one line a second per
    servo. A servo that goes silent and answers again more often (a noisy line) gets one line a
    second with its present state and how many changes were left out, and a change left out is
    logged once its second has passed if the servo is still in that state, so the last line of a
    servo always tells its state."""

    def __init__(self, emit: Callable[[int, str], None], interval_s: float = LINE_INTERVAL_S) -> None:
        self._emit = emit
        self.interval_s = interval_s
        # ID -> [time of its last line, answering as that line said, changes left out since]
        self._last: dict[int, list[Any]] = {}
        self._due: dict[int, bool] = {}  # ID -> the state of a change left out, to log when its second is over

    def change(self, dxl_id: int, answering: bool, now: float | None = None) -> None:
        """``dxl_id`` went silent (``answering`` False) or answers again."""
        now = time.monotonic() if now is None else now
        last = self._last.get(dxl_id)
        if last is not None and now - last[0] < self.interval_s:
            last[2] += 1
            self._due[dxl_id] = answering
            return
        self._line(dxl_id, answering, now, last[2] if last is not None else 0)

    def flush(self, now: float | None = None) -> None:
        """The changes left out whose second is over, where the state differs from the last line."""
        if not self._due:
            return
        now = time.monotonic() if now is None else now
        for dxl_id, answering in list(self._due.items()):
            last = self._last[dxl_id]
            if now - last[0] < self.interval_s:
                continue
            del self._due[dxl_id]
            if answering != last[1]:
                self._line(dxl_id, answering, now, last[2] - 1)

    def forget(self, dxl_id: int) -> None:
        """The servo is no longer handled."""
        self._last.pop(dxl_id, None)
        self._due.pop(dxl_id, None)

    def _line(self, dxl_id: int, answering: bool, now: float, more: int) -> None:
        self._last[dxl_id] = [now, answering, 0]
        self._due.pop(dxl_id, None)
        text = f"ID {dxl_id}: answers again" if answering else f"ID {dxl_id}: no response (ping false)"
        if more > 0:
            text += f" ({more} more changes between silent and answering in the last {self.interval_s:g} s)"
        self._emit(logging.INFO if answering else logging.WARNING, text)
