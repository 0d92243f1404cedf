"""Log hygiene for input the node does not control: repeated warnings at most once a second, user
values cut short, long ID lists named by their first few. ROS-free.

A script that sends a bad command at 100 Hz, or a 100 kB string, must not flood the log: the
first line of a cause is logged at once, the repeats within ``interval_s`` are only counted, and
the next line of that cause says how many were left out.
"""
from __future__ import annotations

import re
import threading
import time
from typing import Callable, Iterable

#: longest user value echoed into a log line [characters]
ECHO_MAX = 80
#: longest file path echoed whole: a workspace's install path runs past ECHO_MAX, and a path cut
#: short names no file (PATH_MAX is 4096: a hostile one is still bounded)
PATH_ECHO_MAX = 240
#: IDs a line names before it only counts the rest
IDS_SHOWN = 5
#: a float, so that "= 12.5" and "= 13.5" count as the same cause (integers, the IDs, are kept)
_FLOAT = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+(?=[eE]))(?:[eE][-+]?\d+)?|\b(?:nan|inf)\b")


def cut(value: object, limit: int = ECHO_MAX) -> str:
    """``str(value)``, cut to ``limit`` characters with the length of the whole when longer."""
    text = str(value)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} characters)"


def cut_path(path: object) -> str:
    """A file path as a line names it: whole up to ``PATH_ECHO_MAX`` characters."""
    return cut(path, PATH_ECHO_MAX)


def some_ids(ids: Iterable[int], shown: int = IDS_SHOWN) -> str:
    """"9", "9, 10 and 11", "9, 10, 11, 12, 13 and 9995 more"."""
    ids = list(ids)
    head = ", ".join(str(i) for i in ids[:shown])
    if len(ids) > shown:
        return f"{head} and {len(ids) - shown} more"
    if len(ids) > 1:
        return f"{', '.join(str(i) for i in ids[:-1])} and {ids[-1]}"
    return head


class Throttle:
    """Logs a line at most once per ``interval_s`` per cause; the key is the line with its
    floating-point values masked, unless the caller names one."""

    MAX_KEYS = 4096  # distinct causes remembered; beyond, the oldest are forgotten

    def __init__(self, log: Callable[[str], None], interval_s: float = 1.0) -> None:
        self._log = log
        self.interval_s = interval_s
        self._last: dict[str, tuple[float, int]] = {}  # key -> (time logged, repeats left out since)
        self._lock = threading.Lock()

    def __call__(self, msg: str, key: str | None = None) -> bool:
        """Log ``msg`` unless its cause was logged less than ``interval_s`` ago; True if logged."""
        key = _FLOAT.sub("#", msg) if key is None else key
        now = time.monotonic()
        with self._lock:
            last = self._last.get(key)
            if last is not None and now - last[0] < self.interval_s:
                self._last[key] = (last[0], last[1] + 1)
                return False
            more = last[1] if last is not None else 0
            self._last.pop(key, None)
            self._last[key] = (now, 0)
            if len(self._last) > self.MAX_KEYS:
                for old in list(self._last)[: len(self._last) - self.MAX_KEYS]:
                    del self._last[old]
        self._log(f"{msg} ({more} more)" if more else msg)
        return True
