"""Small helpers shared by the benchmark scripts: CPU time of a process, period statistics."""
from __future__ import annotations

import os
import subprocess
import threading
import time
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


def machine_cpu_seconds() -> float:
    """CPU time all cores have spent busy so far (everything but idle and iowait), from /proc/stat."""
    with open("/proc/stat") as handle:
        fields = [int(x) for x in handle.readline().split()[1:]]
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)
    return (sum(fields[:8]) - idle) / _TICKS


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


def raise_priority(nice: int = -10) -> str:
    """Lower this process's nice value (inherited by the node and SDK processes it starts), so
    other work on a shared machine takes less CPU from the measured processes. Needs root or
    CAP_SYS_NICE; returns what was applied."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, nice)
        return f"nice {nice}"
    except (PermissionError, OSError):
        return f"nice {os.getpriority(os.PRIO_PROCESS, 0)} (could not lower it)"


def coarse_physics(step_s: float = 0.005) -> str:
    """Let the virtual servos advance their motion model at most every ``step_s`` instead of at
    every instruction, in this process only.

    The virtual bus stands in for hardware, whose servos answer in parallel and in no time next to
    the wire; in Python each servo's refresh (motion model + every present register) costs about
    0.1 ms per instruction, so a 12-servo sync write + sync read would cost the simulator 2.5 ms,
    as long as the wire itself (3.5 ms at 1 Mbps), and every contender would measure the simulator.
    Registers are then at most ``step_s`` old, which no figure here depends on."""
    from dynamixel_handler.sim.dynamics import Dynamics

    exact = getattr(Dynamics, "_bench_exact_refresh", Dynamics.refresh)

    def refresh(self, now: float) -> None:
        if now - self._t >= step_s or now < self._t:
            exact(self, now)

    refresh.__doc__ = exact.__doc__
    Dynamics._bench_exact_refresh = exact
    Dynamics.refresh = refresh
    return f"servo motion refreshed every {1000 * step_s:g} ms"


def wait_for_states(stamps: Sequence[float], node_proc, settle_s: float = 1.0) -> None:
    """Until the node under measure has published 20 states (at most a minute), then ``settle_s``."""
    deadline = time.monotonic() + 60
    while len(stamps) < 20 and time.monotonic() < deadline and node_proc.poll() is None:
        time.sleep(0.1)
    time.sleep(settle_s)


def stop_all(node_proc, executor, node, context) -> None:
    """The node under measure stopped (killed after 20 s), then the bench's own ROS side."""
    node_proc.terminate()
    try:
        node_proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        node_proc.kill()
    executor.shutdown()
    node.destroy_node()
    rclpy_shutdown(context)


def rclpy_shutdown(context) -> None:
    import rclpy
    rclpy.shutdown(context=context)
