#!/usr/bin/env python3
"""The node's loop while the set-up tool works through it: ``dynamixel_handler_setup get`` and
``set`` one after another on a port the node holds (``dynamixel/get_items``, ``dynamixel/set_items``)
against the same node with no tool, in one run.

    source env.sh && python bench/tool_through_node.py [--n 12] [--seconds 8] [--rates 100,2000]

The virtual bus serves ``--n`` XM430-W350 (IDs 1..n) at 1 Mbps with wire timing, in a process of
its own (``sim_process.BusProcess``). For each ``loop_rate`` (2000: flat out) the real node runs on
it; its loop rate is the rate of ``/dynamixel/states`` (one per loop: the present values every loop),
over three windows: no tool,
the tool in a loop (``get 1-N present_temperature``, ``get 1 firmware_version``, ``set 1
profile_velocity``, each a process of its own, as a person or a script runs them), no tool again.
Then a fourth window: ``dynamixel/get_items`` of every servo called back to back by one client of
this process (the loop's own share of the work, without the tool processes' start-up on the CPU).
Prints each window's rate, its longest gap between two loops, the tool's calls and their mean
time, and the ratio with the tool to without (the mean of the two windows without). Figures go to
docs/performance.md by hand. Not part of the test suite.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import stop_all, wait_for_states  # noqa: E402

XM430 = 1020
BAUD = 1_000_000


def _tool_loop(device: str, n: int, stop: threading.Event, times: list[float], failures: list[str]) -> None:
    tool = shutil.which("dynamixel_handler_setup") or "dynamixel_handler_setup"
    calls = [["get", f"1-{n}", "present_temperature"], ["get", "1", "firmware_version"],
             ["set", "1", "profile_velocity", "30rpm"], ["set", "1", "profile_velocity", "0rpm"]]
    k = 0
    while not stop.is_set():
        t0 = time.monotonic()
        out = subprocess.run([tool, "--device", device, *calls[k % len(calls)]], capture_output=True, text=True,
                             timeout=60)
        times.append(time.monotonic() - t0)
        if out.returncode != 0 or "through the running node" not in out.stdout:
            failures.append((out.stdout + out.stderr).strip()[-300:])
        k += 1


def _service_loop(node, n: int, stop: threading.Event, times: list[float], failures: list[str]) -> None:
    """``dynamixel/get_items`` of every servo's Present Temperature, back to back, from this process."""
    from dynamixel_handler_msgs.srv import GetItems

    client = node.create_client(GetItems, "/dynamixel/get_items")
    client.wait_for_service(timeout_sec=10)
    while not stop.is_set():
        t0 = time.monotonic()
        done = threading.Event()
        future = client.call_async(GetItems.Request(ids=list(range(1, n + 1)), items=["present_temperature"]))
        future.add_done_callback(lambda _f: done.set())
        if not done.wait(30) or not future.result().success:
            failures.append("get_items: no answer or not success")
        times.append(time.monotonic() - t0)


def _during(stamps: list[float], seconds: float, loop, *args) -> tuple[tuple[float, float], int, float, list[str]]:
    """The window while ``loop`` runs in a thread: (rate, gap), calls, mean time of a call, failures."""
    stop, times, failures = threading.Event(), [], []
    worker = threading.Thread(target=loop, args=(*args, stop, times, failures), daemon=True)
    worker.start()
    time.sleep(2.0)  # the first call's start-up
    got = _window(stamps, seconds)
    stop.set()
    worker.join()
    return got, len(times), sum(times) / max(1, len(times)), failures


def _window(stamps: list[float], seconds: float) -> tuple[float, float]:
    """(loops a second, longest gap [ms]) of /dynamixel/states over the next ``seconds``."""
    first, t0 = len(stamps), time.monotonic()
    time.sleep(seconds)
    got = stamps[first:]
    gaps = [b - a for a, b in zip(got, got[1:])]
    return (len(got) / (time.monotonic() - t0), 1000.0 * max(gaps, default=0.0))


def run_node(device: str, n: int, rate: int, seconds: float) -> dict:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from dynamixel_handler_msgs.msg import DxlStates

    cmd = [sys.executable, "-m", "dynamixel_handler.ros.node", "--ros-args", "-p", f"device_name:={device}",
           "-p", f"baudrate:={BAUD}", "-p", "latency_timer:=1", "-p", f"loop_rate:={rate}",
           "-p", f"init/expected_servo_num:={n}", "-p", f"init/servo_auto_search.max_id:={n}",
           "-p", "init/servo_auto_search.retry_times:=5", "-p", "verbose_ratio:=0",
           "-p", "pub_ratio/present.current:=1", "-p", "pub_ratio/present.velocity:=1", "-p", "pub_ratio/present.position:=1"]
    node_proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node(f"bench_tool_{os.getpid()}", context=context)
    stamps: list[float] = []
    node.create_subscription(DxlStates, "/dynamixel/states", lambda _m: stamps.append(time.monotonic()),
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    try:
        wait_for_states(stamps, node_proc)
        before = _window(stamps, seconds)
        during, calls, call_s, failures = _during(stamps, seconds, _tool_loop, device, n)
        after = _window(stamps, seconds)
        served, requests, request_s, _ = _during(stamps, seconds, _service_loop, node, n)
    finally:
        stop_all(node_proc, executor, node, context)
    return {"before": before, "during": during, "after": after, "calls": calls, "call_s": call_s,
            "failures": failures, "served": served, "requests": requests, "request_s": request_s}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--rates", default="100,2000", help="loop_rate values (2000: flat out)")
    a = ap.parse_args(argv)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from bench_loop import claim_domain
    os.environ["ROS_DOMAIN_ID"] = claim_domain()
    from sim_process import BusProcess

    bus = BusProcess(servos={i: XM430 for i in range(1, a.n + 1)}, baudrate=BAUD, wire_timing=True)
    rows = []
    try:
        for rate in (int(r) for r in a.rates.split(",")):
            rows.append((rate, run_node(bus.path, a.n, rate, a.seconds)))
    finally:
        bus.close()
    print(f"{a.n} XM430-W350 at 1 Mbps, latency timer 1 ms, {a.seconds:g} s windows, "
          f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, load average {os.getloadavg()[0]:.2f}")
    n = a.n
    for rate, r in rows:
        base = (r["before"][0] + r["after"][0]) / 2
        print(f"  loop_rate {rate}: no tool {r['before'][0]:7.1f} Hz (longest gap {r['before'][1]:5.1f} ms) | "
              f"tool working {r['during'][0]:7.1f} Hz (longest gap {r['during'][1]:5.1f} ms; {r['calls']} calls, "
              f"{r['call_s']:.2f} s each) | no tool again {r['after'][0]:7.1f} Hz (longest gap {r['after'][1]:5.1f} ms) "
              f"| with / without {r['during'][0] / base:.3f}")
        print(f"    get_items of {n} servos back to back from one client: {r['served'][0]:7.1f} Hz (longest gap "
              f"{r['served'][1]:5.1f} ms; {r['requests']} requests, {1000 * r['request_s']:.0f} ms each) | "
              f"with / without {r['served'][0] / base:.3f}")
        for failure in r["failures"][:3]:
            print(f"    a call failed: {failure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
