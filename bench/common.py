"""Small helpers shared by the benchmark scripts: CPU time of a process, period statistics."""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from typing import Sequence

import numpy as np

_TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time a process has used so far (all its threads), from /proc/<pid>/stat."""
    with open(f"/proc/{pid}/stat") as handle:
        text = handle.read()
    fields = text[text.rindex(")") + 2:].split()  # after "pid (comm) "; the comm may contain spaces
    utime, stime = int(fields[11]), int(fields[12])  # fields 14 and 15 of proc(5), counted from 1
    return (utime + stime) / _TICKS


@dataclass(frozen=True)
class Periods:
    """Loop periods measured between consecutive occurrences of the same event."""

    count: int
    rate_hz: float      # events per second over the window
    mean_s: float
    p99_s: float
    max_s: float

    @staticmethod
    def of(times: Sequence[float], window_s: float) -> "Periods":
        t = np.asarray(sorted(times), dtype=np.float64)
        if len(t) < 2:
            return Periods(len(t), len(t) / window_s if window_s > 0 else 0.0, float("nan"), float("nan"),
                           float("nan"))
        d = np.diff(t)
        return Periods(len(t), len(t) / window_s, float(d.mean()), float(np.percentile(d, 99)), float(d.max()))


def hardware_priority(thread_name: str = "dxl-virtual-bus") -> str:
    """Give the virtual bus's serving thread real-time priority, so it answers on time like servos
    do, whatever else the machine runs; the contenders (node, SDK loop) keep normal priority.
    Returns what was applied (SCHED_FIFO needs root or CAP_SYS_NICE; otherwise nothing changes)."""
    for thread in threading.enumerate():
        if thread.name == thread_name and thread.native_id is not None:
            try:
                os.sched_setscheduler(thread.native_id, os.SCHED_FIFO, os.sched_param(10))
                return "virtual bus thread at SCHED_FIFO 10"
            except (PermissionError, OSError) as exc:
                return f"virtual bus thread at normal priority ({exc.strerror or exc})"
    return "virtual bus thread not found"
