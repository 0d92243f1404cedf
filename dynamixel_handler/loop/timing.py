"""Timer precision for the loop thread.

Linux lets the kernel defer a sleeping thread's wake-up by its *timer slack* (50 µs by default)
to batch wake-ups. The loop sleeps several times a loop (until the next period, until the replies
of a read are due, through the wire time of the rest of a reply), so the default slack adds up to
a few tenths of a millisecond a loop. A slack of 1 µs costs nothing measurable in CPU.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import sys

#: prctl(2) option that sets the calling thread's timer slack
PR_SET_TIMERSLACK = 29
PR_GET_TIMERSLACK = 30
#: timer slack of the loop thread [ns]
LOOP_TIMER_SLACK_NS = 1000


def _libc() -> "ctypes.CDLL | None":
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        return None


def set_timer_slack(ns: int = LOOP_TIMER_SLACK_NS) -> int | None:
    """Set the calling thread's timer slack to ``ns`` nanoseconds; returns the slack now in effect,
    or None where it cannot be set (not Linux, prctl refused). Never raises."""
    libc = _libc()
    if libc is None:
        return None
    try:
        if libc.prctl(PR_SET_TIMERSLACK, ctypes.c_ulong(max(1, int(ns))), 0, 0, 0) != 0:
            return None
        return int(libc.prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0))
    except (AttributeError, OSError):
        return None
