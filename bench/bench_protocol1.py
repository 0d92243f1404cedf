#!/usr/bin/env python3
"""Protocol 1.0 loop benchmark: a bus of AX-12A servos at 1 Mbps, the node against bare
``dynamixel_sdk`` Protocol 1.0 doing the same work, in one run.

    source env.sh && python bench/bench_protocol1.py [--n 6] [--seconds 5] [--repeat 1]

The virtual bus serves ``--n`` AX-12A (IDs 1..n) at 1 Mbps with wire timing, in a process of its
own (``sim_process.BusProcess``). One loop, both sides: each servo's Present Position, Speed and
Load read (one READ of 6 bytes at address 36 per servo: Protocol 1.0 has no Sync Read) and one
SYNC WRITE of Goal Position to all of them.

- SDK: ``PacketHandler(1.0).readTxRx`` per servo and a ``GroupSyncWrite`` per loop, flat out, its
  own process (``--sdk`` mode of this script), reply timeouts with the same latency timer as the node.
- node: the real node (own process) at ``loop_rate`` 2000 (flat out) and 100, a controller in this
  process publishing one ``/dynamixel/command/goal`` (positions of every servo) per
  ``/dynamixel/states`` it receives, so the node writes one sync write per loop too. Its loop rate
  is the rate of ``/dynamixel/states`` (one per loop: ``pub_ratio`` 1 for the present values).

Prints node Hz, SDK Hz and their ratio, the node's CPU (% of one core) and, at 100 Hz, whether the
rate was held. Figures go to docs/performance.md by hand. Not part of the test suite.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
AX12A = 12
PRESENT_ADDRESS, PRESENT_LENGTH = 36, 6  # Present Position, Speed, Load
GOAL_ADDRESS, GOAL_LENGTH = 30, 2
BAUD = 1_000_000
LATENCY_MS = 1.0


def sdk_loop(device: str, n: int, seconds: float) -> dict:
    """The bare SDK loop (run in a process of its own)."""
    from common import cpu_seconds
    from dynamixel_sdk import COMM_SUCCESS, GroupSyncWrite, PacketHandler, PortHandler

    port = PortHandler(device)
    assert port.openPort() and port.setBaudRate(BAUD)
    ph = PacketHandler(1.0)
    writer = GroupSyncWrite(port, ph, GOAL_ADDRESS, GOAL_LENGTH)
    ids = list(range(1, n + 1))
    goals = [(412 + k % 200).to_bytes(2, "little") for k in range(200)]
    loops = failures = 0
    start = time.monotonic()
    begin, end = start + 1.0, start + 1.0 + seconds
    cpu0 = None
    counted = 0
    while True:
        now = time.monotonic()
        if now >= end:
            break
        if cpu0 is None and now >= begin:
            cpu0, begin, counted = cpu_seconds(os.getpid()), now, 0
        writer.clearParam()
        for i in ids:
            writer.addParam(i, goals[loops % len(goals)])
        writer.txPacket()
        for i in ids:
            _, result, _ = ph.readTxRx(port, i, PRESENT_ADDRESS, PRESENT_LENGTH)
            failures += result != COMM_SUCCESS
        loops += 1
        counted += 1
    window = time.monotonic() - begin
    cpu = cpu_seconds(os.getpid()) - (cpu0 or 0.0)
    port.closePort()
    return {"rate_hz": counted / window, "cpu_percent": 100.0 * cpu / window, "failures": failures}


def run_sdk(device: str, n: int, seconds: float) -> dict:
    out = subprocess.run([sys.executable, __file__, "--sdk", device, "--n", str(n), "--seconds", str(seconds)],
                         capture_output=True, text=True, timeout=seconds + 60)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_node(device: str, n: int, rate: int, seconds: float) -> dict:
    """The node on ``device`` at ``loop_rate`` ``rate``, driven by a controller; its loop rate and CPU."""
    import rclpy
    from common import cpu_seconds, stop_all, wait_for_states
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from dynamixel_handler_msgs.msg import DxlStates, DynamixelGoal

    ids = list(range(1, n + 1))
    cmd = [sys.executable, "-m", "dynamixel_handler.ros.node", "--ros-args",
           "-p", f"device_name:={device}", "-p", f"baudrate:={BAUD}", "-p", f"latency_timer:={int(LATENCY_MS)}",
           "-p", f"loop_rate:={rate}", "-p", "init/used_servo_series.AX:=true", "-p", "init/used_servo_series.X:=false",
           "-p", f"init/expected_servo_num:={n}", "-p", f"init/servo_auto_search.max_id:={n}",
           "-p", "init/servo_auto_search.retry_times:=5", "-p", "verbose_ratio:=0", "-p", "pub_ratio/present.current:=1",
           "-p", "pub_ratio/present.velocity:=1", "-p", "pub_ratio/present.position:=1"]
    node_proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node(f"bench_protocol1_{os.getpid()}", context=context)
    pub = node.create_publisher(DynamixelGoal, "/dynamixel/command/goal", 10)
    stamps: list[float] = []
    k = [0]

    def on_states(_msg) -> None:
        stamps.append(time.monotonic())
        k[0] += 1
        pub.publish(DynamixelGoal(id_list=ids, position_deg=[float(k[0] % 40 - 20)] * n))

    node.create_subscription(DxlStates, "/dynamixel/states", on_states,
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    spinning.start()
    try:
        wait_for_states(stamps, node_proc)
        first, cpu0, t0 = len(stamps), cpu_seconds(node_proc.pid), time.monotonic()
        time.sleep(seconds)
        last, cpu1, t1 = len(stamps), cpu_seconds(node_proc.pid), time.monotonic()
    finally:
        stop_all(node_proc, executor, node, context)
    window = t1 - t0
    return {"rate_hz": (last - first) / window, "cpu_percent": 100.0 * (cpu1 - cpu0) / window}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=6)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--sdk", metavar="DEVICE", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.sdk:
        print(json.dumps(sdk_loop(a.sdk, a.n, a.seconds)), flush=True)
        return 0
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from bench_loop import claim_domain
    os.environ["ROS_DOMAIN_ID"] = claim_domain()
    from sim_process import BusProcess

    bus = BusProcess(servos={i: AX12A for i in range(1, a.n + 1)}, baudrate=BAUD, wire_timing=True)
    for i in range(1, a.n + 1):  # as the node sets it (default/return_delay_time 0): the same wire for both
        bus.write(i, "return_delay_time", 0)
    rows = []
    try:
        for _ in range(a.repeat):
            sdk = run_sdk(bus.path, a.n, a.seconds)
            flat = run_node(bus.path, a.n, 2000, a.seconds)
            held = run_node(bus.path, a.n, 100, a.seconds)
            rows.append((sdk, flat, held))
    finally:
        bus.close()
    print(f"{a.n} AX-12A at 1 Mbps, latency timer {LATENCY_MS:g} ms, {a.seconds:g} s windows, "
          f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}")
    for sdk, flat, held in rows:
        print(f"  SDK {sdk['rate_hz']:7.1f} Hz (CPU {sdk['cpu_percent']:5.1f} %, {sdk['failures']} failed reads) | "
              f"node flat out {flat['rate_hz']:7.1f} Hz (CPU {flat['cpu_percent']:5.1f} %), node/SDK "
              f"{flat['rate_hz'] / sdk['rate_hz']:.2f} | node at loop_rate 100: {held['rate_hz']:6.1f} Hz "
              f"(CPU {held['cpu_percent']:4.1f} %)")
    if len(rows) > 1:
        print(f"  median node/SDK {statistics.median(f['rate_hz'] / s['rate_hz'] for s, f, _ in rows):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
