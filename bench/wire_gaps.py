"""Where the wire waits for the host: per-loop gaps from the virtual bus log, SDK against the node.

The loop rate is the wire time of one cycle plus the time the line stands idle because the host
has not sent the next packet yet. This script runs the bare SDK cycle and the node (flat out, one
command per state message, as ``bench_loop.py`` does) on the same virtual bus and rebuilds, from the
bus log, when each read's last reply byte left the virtual servos (the bus's own timing rule). It
prints, for each contender:

- ``reply -> next packet``: from the end of a read's replies until the host's next packet arrives
  (noticing the reply, parsing it, building and writing the goals) — the SDK polls, the node blocks;
- ``write -> read idle``: how long the line stood idle between the goal write's last byte and the
  next read's first byte (0 when the read was queued behind the write in time);
- the mean cycle (read end to read end).

    python bench/wire_gaps.py                    # 12 servos, 1 Mbps, latency 0, both read methods
    python bench/wire_gaps.py --n 30 --latency-ms 1 --fast
"""
from __future__ import annotations

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench_loop  # noqa: E402  (claims a ROS domain and keeps discovery local before rclpy starts)
import numpy as np  # noqa: E402
import wire  # noqa: E402
from common import raise_priority  # noqa: E402
from node_run import Controller, measure_node  # noqa: E402
from sim_process import BusProcess  # noqa: E402

from dynamixel_handler.protocol import host  # noqa: E402

READS = (host.SYNC_READ, host.FAST_SYNC_READ)


def reply_bytes(entry) -> int:
    if entry.instruction == host.FAST_SYNC_READ:
        return 8 + len(entry.ids) * (entry.length + 4)
    return len(entry.ids) * (host.STATUS_OVERHEAD + entry.length)


def gaps(log, baudrate: int, latency_s: float) -> dict[str, np.ndarray]:
    """Replays the bus's timing rule over its log: each packet starts when it arrived or when the
    line was free, whichever is later; a read's replies follow its packet after the latency."""
    byte_s = 10.0 / baudrate
    free = 0.0
    reply_to_next, idle_before_read, cycles = [], [], []
    prev = None
    last_read_end = None
    for entry in log:
        size = len(host.build_instruction(host.BROADCAST_ID, entry.instruction, entry.params))
        start = max(entry.time, free)
        end = start + size * byte_s
        if prev is not None and prev.instruction in READS:
            reply_to_next.append(entry.time - free)
        if entry.instruction in READS:
            if prev is not None and prev.instruction == host.SYNC_WRITE:
                idle_before_read.append(max(0.0, entry.time - free))
            end += latency_s + reply_bytes(entry) * byte_s
            if last_read_end is not None:
                cycles.append(end - last_read_end)
            last_read_end = end
        free = end
        prev = entry
    return {"reply": np.array(reply_to_next), "idle": np.array(idle_before_read), "cycle": np.array(cycles)}


def describe(name: str, rate_hz: float, found: dict[str, np.ndarray]) -> str:
    def ms(values: np.ndarray, q: float) -> str:
        return f"{1000 * np.percentile(values, q):.3f}" if len(values) else "-"
    reply, idle, cycle = found["reply"], found["idle"], found["cycle"]
    idle_share = float(np.mean(idle > 1e-5)) if len(idle) else 0.0
    return (f"{name:5s} {rate_hz:6.0f} Hz | reply -> next packet p50 {ms(reply, 50)} p90 {ms(reply, 90)} ms | "
            f"write -> read idle in {100 * idle_share:3.0f} % of loops, mean {1000 * idle.mean() if len(idle) else 0:.3f} ms | "
            f"cycle mean {1000 * cycle.mean() if len(cycle) else float('nan'):.3f} ms")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--baud", type=int, default=1_000_000)
    ap.add_argument("--latency-ms", type=float, default=0.0)
    ap.add_argument("--fast", action="store_true", help="Fast Sync Read only (default: both read methods)")
    ap.add_argument("--window", type=float, default=2.0, help="seconds measured per contender")
    a = ap.parse_args()
    latency_s = a.latency_ms / 1000
    print(f"{a.n} servos, {a.baud} bps, latency {a.latency_ms:g} ms, {raise_priority()}", flush=True)
    import rclpy
    rclpy.init()
    controller = Controller("bundle")
    try:
        for fast in ([True] if a.fast else [False, True]):
            sim = BusProcess(False, servos={i: bench_loop.X_MODEL for i in range(1, a.n + 1)},
                             baudrate=a.baud, latency_s=latency_s)
            try:
                for i in range(1, a.n + 1):
                    sim.write(i, "return_delay_time", 0)
                sim.clear_log()
                sdk = bench_loop.sdk_run(sim.path, a.n, a.baud, latency_s, fast, a.window)
                sdk_log = sim.log
                sim.clear_log()
                node = measure_node(sim, controller, a.n, a.baud, latency_s, 2000, fast, a.window)
                node_log = commanded(sim.log)
            finally:
                sim.close()
            limit = wire.cycle(a.n, a.baud, latency_s, fast)
            print(f"\n{'Fast Sync Read' if fast else 'Sync Read'}: wire limit {limit.rate_hz:.0f} Hz "
                  f"({1000 / limit.rate_hz:.3f} ms a cycle)")
            print(describe("sdk", sdk["rate_hz"], gaps(sdk_log, a.baud, latency_s)))
            if node.error:
                print(f"node  run failed: {node.error}")
            else:
                print(describe("node", node.rate_hz, gaps(node_log, a.baud, latency_s)))
    finally:
        controller.close()
        rclpy.try_shutdown()
    return 0


def commanded(log) -> list:
    """The part of the node's log from its first goal write to its last (start-up excluded)."""
    writes = [e.time for e in log if e.instruction == host.SYNC_WRITE and e.address == wire.GOAL_ADDRESS]
    return [e for e in log if writes and writes[0] <= e.time <= writes[-1]]


if __name__ == "__main__":
    sys.exit(main())
