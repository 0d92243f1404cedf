#!/usr/bin/env python3
"""The E-stop's reaction time: from ``dynamixel/e_stop`` published to the hold on the wire.

    source env.sh && python bench/e_stop_latency.py [--repeats 20]

The real node on a virtual bus with wire timing (X servos at 1 Mbps, adapter latency 1 ms), 1 and
12 servos, ``loop_rate`` 100 and flat out (2000). The servos are in velocity mode and turning, so the
hold is a Sync Write of Goal Velocity 0 to all of them. Each repeat: engage (``time.monotonic()``
just before ``publish``), find the first Sync Write of Goal Velocity after it that carries 0 for
every servo (the simulator's log, same clock), release, command the servos to turn again.

Printed per case: median and longest reaction [ms], and as the baseline measured in the same run
the period of the loop's present-position reads (the shipped config reads it every 2nd loop: 20 ms
at loop_rate 100): the ratio says how many of those periods the stop takes. The figures go to
docs/reliability.md by hand. Not part of the test suite.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import abuse  # noqa: E402  (sets the ROS environment of the bench: localhost, a domain of its own)

X = 1020
GOAL_VELOCITY = 104
SYNC_WRITE = 0x83


class Operator:
    """An rclpy node in this process: the E-stop and velocity commands."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from std_msgs.msg import Bool

        from dynamixel_handler_msgs.msg import DynamixelControlXVelocity
        rclpy.init()
        self.node = Node("e_stop_bench")
        self.Bool, self.Velocity = Bool, DynamixelControlXVelocity
        self.stop = self.node.create_publisher(Bool, "/dynamixel/e_stop", 10)
        self.velocity = self.node.create_publisher(DynamixelControlXVelocity, "/dynamixel/command/x/velocity_control", 10)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self._spin = True
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _loop(self) -> None:
        while self._spin:
            self.executor.spin_once(timeout_sec=0.05)

    def matched(self) -> bool:
        return self.stop.get_subscription_count() > 0 and self.velocity.get_subscription_count() > 0

    def close(self) -> None:
        self._spin = False
        self.thread.join(1.0)
        self.executor.shutdown()
        self.node.destroy_node()


def _hold_written(sim, since: float, ids: list[int]) -> float | None:
    """Log time of the first Sync Write of Goal Velocity after ``since`` giving every servo 0."""
    for e in list(sim.log):
        if e.time < since or e.instruction != SYNC_WRITE or not e.address <= GOAL_VELOCITY < e.address + (e.length or 0):
            continue
        zero, seen = True, set()
        for k in range(4, len(e.params), 1 + e.length):
            dxl_id = e.params[k]
            data = bytes(e.params[k + 1 + GOAL_VELOCITY - e.address:][:4])
            seen.add(dxl_id)
            zero = zero and int.from_bytes(data, "little", signed=True) == 0
        if zero and seen >= set(ids):
            return e.time
    return None


def _loop_period(sim, t0: float, t1: float) -> float:
    rate, _gap = abuse.loop_figures(sim, t0, t1)
    return 1.0 / rate if rate > 0 else float("nan")


def case(VirtualBus, op: Operator, n: int, loop_rate: int, repeats: int) -> dict:
    ids = list(range(1, n + 1))
    sim = VirtualBus(servos={i: X for i in ids}, baudrate=1_000_000, wire_timing=True)
    node = abuse.Node(sim, "baudrate:=1000000", f"loop_rate:={loop_rate}", "verbose_ratio:=0",
                      "init/servo_auto_search.min_id:=1", f"init/servo_auto_search.max_id:={n}",
                      f"init/expected_servo_num:={n}")
    try:
        node.wait_for("loop running")
        deadline = time.monotonic() + 10
        while not op.matched() and time.monotonic() < deadline:
            time.sleep(0.05)
        reactions = []
        t_start = time.monotonic()
        for _ in range(repeats):
            op.velocity.publish(op.Velocity(id_list=ids, velocity_deg_s=[30.0] * n))
            time.sleep(0.3)
            t = time.monotonic()
            op.stop.publish(op.Bool(data=True))
            end = t + 2.0
            written = None
            while written is None and time.monotonic() < end:
                time.sleep(0.01)
                written = _hold_written(sim, t, ids)
            if written is not None:
                reactions.append(written - t)
            op.stop.publish(op.Bool(data=False))
            time.sleep(0.1)
        period = _loop_period(sim, t_start, time.monotonic())
        return {"n": n, "loop_rate": loop_rate, "count": len(reactions), "repeats": repeats,
                "median_ms": 1000 * statistics.median(reactions) if reactions else float("nan"),
                "max_ms": 1000 * max(reactions) if reactions else float("nan"), "period_ms": 1000 * period}
    finally:
        node.stop()
        sim.stop()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    from dynamixel_handler.sim import VirtualBus
    op = Operator()
    rows = []
    try:
        for n in (1, 12):
            for loop_rate in (100, 2000):
                rows.append(case(VirtualBus, op, n, loop_rate, args.repeats))
                r = rows[-1]
                print(f"{r['n']:>2} servo(s), loop_rate {r['loop_rate']:>4}: reaction median {r['median_ms']:.1f} ms, "
                      f"longest {r['max_ms']:.1f} ms ({r['count']}/{r['repeats']} holds seen); present-read period "
                      f"{r['period_ms']:.2f} ms: median {r['median_ms'] / r['period_ms']:.1f} read periods", flush=True)
    finally:
        op.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
