#!/usr/bin/env python3
"""Repeated 100,000-point FollowJointTrajectory goals against the real node on a virtual bus: is
the node's memory flat across them?

    source env.sh && python bench/abuse_goals.py [--goals 6] [--points 100000]

The same goal (refused: more points than the maximum) is sent ``--goals`` times; per goal: how it
ended and in how long, the node's RSS before and 2 s after; after every second goal the node calls
malloc_trim(0) (bench/thread_names/sitecustomize.py) and says what it gave back, the Python
allocator's blocks in use, and the MiB in its arenas against the MiB in its blocks (arenas part-used
stay: that is memory the next goal reuses). Figures in docs/reliability.md ("Known limits"). Not
part of the test suite.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import abuse  # noqa: E402  (sets the ROS environment of the bench: localhost, a domain of its own)
import abuse_crowd  # noqa: E402
import crowd_probe  # noqa: E402
from abuse_trajectory import JOINTS, Client  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goals", type=int, default=6)
    ap.add_argument("--points", type=int, default=100_000)
    args = ap.parse_args()
    from dynamixel_handler.sim import VirtualBus
    sim = VirtualBus(servos={1: abuse.X, 2: abuse.X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=2", "init/expected_servo_num:=2", *JOINTS,
                      env={"PYTHONPATH": os.pathsep.join([crowd_probe.THREAD_NAMES, os.environ.get("PYTHONPATH", "")]),
                           "DXL_BENCH_TRIM": abuse_crowd.TRIM})
    node.wait_for("loop running")
    time.sleep(2.0)
    client = Client()
    try:
        print(f"idle: rss {node.resources()[0]} MiB; {abuse_crowd._trimmed()}", flush=True)
        goal = client.goal(args.points, 10.0)
        for k in range(args.goals):
            before = node.resources()[0]
            accepted, _status, code, text, took = client.run(goal, timeout=60)
            time.sleep(2.0)
            trim = abuse_crowd._trimmed() if k % 2 else ""
            print(f"goal {k + 1}: accepted {accepted}, code {code} in {took:.2f} s ('{text[:40]}'); rss before "
                  f"{before}, 2 s after {node.resources()[0]} MiB; {trim}", flush=True)
    finally:
        client.close()
        node.stop()
        sim.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
