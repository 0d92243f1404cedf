"""A/B of the node's loop: one revision against the working tree, in one run, on the same buses.

    source env.sh && python bench/ab_loop.py --base d651df3 [--repeat 3] [--window 3]

The base revision is taken out of git into a temporary folder (``git archive``); the node runs
from that folder (A) or from this tree (B), in turns A B A B ... so that a drift of the machine
meets both. Rows: 12 X servos at 1 Mbps and 1 X servo at 4 Mbps (adapter latency 0), flat out
(loop_rate 2000), Fast Sync Read off, a controller answering every states message with a goal
(``node_run.py``). Printed: per row the median loop rate and CPU of A and B, and B / A.
A change of structure that leaves behaviour alone should stay within 5 % on both.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import rclpy  # noqa: E402
from bench_loop import X_MODEL  # noqa: E402  (sets the ROS environment before rclpy is imported)
from common import raise_priority  # noqa: E402
from node_run import ROOT, Controller, measure_node  # noqa: E402
from sim_process import BusProcess  # noqa: E402

ROWS = ((12, 1_000_000), (1, 4_000_000))


def checkout(rev: str, into: Path) -> Path:
    """The package files of ``rev`` in ``into`` (no git state: a plain folder)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "dynamixel_handler", "config"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the revision to compare with (A); B is this tree")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each revision per row")
    ap.add_argument("--window", type=float, default=3.0, help="seconds measured per run")
    a = ap.parse_args(argv)
    nice = raise_priority()
    rclpy.init()
    controller = Controller("bundle")
    began = time.monotonic()
    print(f"A = {a.base}, B = this tree; {a.repeat} runs each per row, {a.window:g} s windows, {nice}, "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    with tempfile.TemporaryDirectory(prefix="dxl_ab_") as folder:
        trees = {"A": checkout(a.base, Path(folder)), "B": ROOT}
        lines = []
        for n, baudrate in ROWS:
            sim = BusProcess(False, servos={i: X_MODEL for i in range(1, n + 1)}, baudrate=baudrate, latency_s=0.0)
            for i in range(1, n + 1):
                sim.write(i, "return_delay_time", 0)
            runs: dict[str, list[tuple[float, float]]] = {"A": [], "B": []}
            try:
                for _ in range(a.repeat):
                    for name, tree in trees.items():
                        sim.clear_log()
                        res = measure_node(sim, controller, n, baudrate, 0.0, 2000, False, a.window, tree=tree)
                        if res.error:
                            print(f"  {name} failed: {res.error}", file=sys.stderr, flush=True)
                            continue
                        runs[name].append((res.rate_hz, res.cpu_percent))
                        print(f"[{time.monotonic() - began:4.0f}s] {n} servo(s) {baudrate // 1_000_000} Mbps {name}: "
                              f"{res.rate_hz:.0f} Hz, CPU {res.cpu_percent:.0f} %", flush=True)
            finally:
                sim.close()
            if runs["A"] and runs["B"]:
                (ra, ca), (rb, cb) = [(statistics.median(r for r, _ in runs[k]), statistics.median(c for _, c in runs[k]))
                                      for k in ("A", "B")]
                lines.append(f"{n:2d} servo(s) {baudrate // 1_000_000} Mbps: rate A {ra:.0f} Hz, B {rb:.0f} Hz, "
                             f"B/A {rb / ra:.3f}; CPU A {ca:.0f} %, B {cb:.0f} %, B/A {cb / ca:.3f}")
    controller.close()
    rclpy.try_shutdown()
    print("\n".join(["medians:"] + lines), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
