"""Where the CPU of a crowd goes: the node's threads (by name, see bench/thread_names), the
simulator's thread, the client processes and the machine, sampled from /proc while a phase runs.

Per thread group: CPU (share of one core over the phase) and the time it waited on a run queue
(ready to run but no core free: /proc/<pid>/task/<tid>/schedstat, field 2). A thread waiting for
Python's interpreter lock sleeps (it is not on a run queue), so a loop thread late with little
run-queue wait was held by the lock or its own work, one late with much of it by the other
processes. Also the node's RSS: the highest sampled. Bench only.
"""
from __future__ import annotations

import os
import threading
import time
from pathlib import Path

#: where bench/thread_names/sitecustomize.py is: on the measured process's PYTHONPATH
THREAD_NAMES = str(Path(__file__).resolve().parent / "thread_names")
#: sampling period [s]
PERIOD_S = 0.1
_TICKS = os.sysconf("SC_CLK_TCK")


def group_of(comm: str) -> str:
    """The group a node thread is counted in, from its kernel name."""
    if comm.startswith("dynamixel_loop"):
        return "loop"
    if comm.startswith("ThreadPool"):
        return "pool"
    if comm == "executor":
        return "spin"
    if comm.startswith("dynamixel_pub"):
        return "publish"
    return "other"  # the main thread, the middleware's threads


def _schedstat(path: str) -> tuple[int, int]:
    try:
        run, wait, _ = Path(path).read_text().split()
        return int(run), int(wait)
    except (OSError, ValueError):
        return 0, 0


def _threads(pid: int) -> dict[int, tuple[str, int, int]]:
    """tid -> (group, CPU ns, run-queue wait ns) of every thread of ``pid``."""
    out = {}
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return out
    for tid in tids:
        try:
            comm = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
        except OSError:
            continue
        out[int(tid)] = (group_of(comm), *_schedstat(f"/proc/{pid}/task/{tid}/schedstat"))
    return out


def _rss_mib(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def _machine_busy_s() -> float:
    with open("/proc/stat") as handle:
        fields = [int(x) for x in handle.readline().split()[1:]]
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)
    return (sum(fields[:8]) - idle) / _TICKS


def _proc_cpu_s(pid: int) -> float:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return 0.0
    fields = text[text.rindex(")") + 2:].split()
    return (int(fields[11]) + int(fields[12])) / _TICKS


class Probe:
    """Samples the node ``pid``, this process's ``sim_tid`` and the ``clients`` pids until ``stop``."""

    def __init__(self, pid: int, sim_tid: int | None, clients: list[int]) -> None:
        self.pid, self.sim_tid, self.clients = pid, sim_tid, clients
        self.first = _threads(pid)
        self.last = dict(self.first)
        self.sim0 = _schedstat(f"/proc/self/task/{sim_tid}/schedstat") if sim_tid else (0, 0)
        self.client_cpu: dict[int, float] = {c: _proc_cpu_s(c) for c in clients}
        self.client0 = dict(self.client_cpu)
        self.machine0 = _machine_busy_s()
        self.rss_peak = _rss_mib(pid)
        self.t0 = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(PERIOD_S):
            self._sample()

    def _sample(self) -> None:
        self.last.update(_threads(self.pid))  # a thread that ended keeps its last figures
        for c in self.clients:
            cpu = _proc_cpu_s(c)
            if cpu > 0:
                self.client_cpu[c] = cpu
        self.rss_peak = max(self.rss_peak, _rss_mib(self.pid))

    def stop(self) -> dict:
        """The figures of the phase: per group CPU % of a core and run-queue wait % of the wall."""
        self._stop.set()
        self._thread.join(1.0)
        self._sample()
        wall = time.monotonic() - self.t0
        groups: dict[str, list[float]] = {}
        for tid, (group, run, wait) in self.last.items():
            _, run0, wait0 = self.first.get(tid, (group, 0, 0))
            g = groups.setdefault(group, [0.0, 0.0, 0.0])
            g[0] += (run - run0) / 1e9
            g[1] += (wait - wait0) / 1e9
            g[2] += 1
        if self.sim_tid:
            run, wait = _schedstat(f"/proc/self/task/{self.sim_tid}/schedstat")
            groups["sim"] = [(run - self.sim0[0]) / 1e9, (wait - self.sim0[1]) / 1e9, 1]
        clients = sum(self.client_cpu[c] - self.client0[c] for c in self.clients)
        return {"wall_s": wall, "groups": {k: (100 * v[0] / wall, 100 * v[1] / wall, int(v[2]))
                                           for k, v in groups.items()},
                "clients_pct": 100 * clients / wall, "machine_pct": 100 * (_machine_busy_s() - self.machine0) / wall,
                "rss_peak": self.rss_peak}


def sim_thread_id() -> int | None:
    """The native id of the virtual bus's serving thread in this process (None if not found)."""
    for thread in threading.enumerate():
        if thread.name.startswith("dxl-virtual-bus") and thread.native_id is not None:
            return thread.native_id
    return None


def loop_fifo(pid: int) -> str:
    """The node's loop thread (by its name) at SCHED_FIFO 5; what was applied."""
    for tid in os.listdir(f"/proc/{pid}/task"):
        if Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip() == "dynamixel_loop":
            try:
                os.sched_setscheduler(int(tid), os.SCHED_FIFO, os.sched_param(5))
                return "the node's loop thread at SCHED_FIFO 5"
            except OSError as exc:
                return f"the node's loop thread at normal priority ({exc.strerror or exc})"
    return "the node's loop thread not found"


def line(figures: dict) -> str:
    """One line: wall, each group's CPU % / run-queue %, the clients' and machine's CPU, peak RSS."""
    order = ("loop", "spin", "pool", "publish", "other", "sim")
    parts = [f"{k} {figures['groups'][k][0]:.0f}/{figures['groups'][k][1]:.0f}%" for k in order
             if k in figures["groups"]]
    return (f"{figures['wall_s']:.1f} s; cpu/runq {' '.join(parts)}; clients {figures['clients_pct']:.0f}%; "
            f"machine {figures['machine_pct']:.0f}% (of 200); rss peak {figures['rss_peak']:.0f} MiB")
