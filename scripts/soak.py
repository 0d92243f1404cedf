#!/usr/bin/env python3
"""Soak run: the node on a 12-servo virtual bus under mixed command load and injected faults.

    source env.sh && python scripts/soak.py --minutes 30      (--minutes 1 for a short look)

Every cycle (~20 s) publishes a burst of commands from another process (10 publishers x 100 Hz)
while one fault is injected: CRC corruption, garbage, truncated replies, a servo that stops
answering and comes back, a hardware error then a clear, the device vanishing and reappearing.
After each fault the script checks that the node is alive, every servo answers again and the
last command of the burst is what every servo holds. At the end it prints the counts: loops,
commands sent / refused / written, faults injected / survived, reconnects, peak memory.
Not part of the test suite (it is long); nothing leaves this machine (pseudo-terminal, loopback DDS).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(60 + os.getpid() % 30))

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from dynamixel_handler.sim import VirtualBus  # noqa: E402

N_SERVOS = 12
FAULTS = ("crc_1pct", "crc_10pct", "garbage", "truncated", "silent_servo", "hardware_error", "vanish")


def rss_kb(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))
    except (OSError, StopIteration):
        return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=30.0)
    ap.add_argument("--burst-s", type=float, default=8.0, help="command burst per cycle [s]")
    args = ap.parse_args()

    tmp = Path(tempfile.mkdtemp(prefix="dxl_soak_"))
    link = str(tmp / "ttyDXL")
    sim = VirtualBus(servos={i: 1020 for i in range(1, N_SERVOS + 1)}, link=link, wire_timing=False)
    sim.start()
    log_path = tmp / "node.log"
    log = open(log_path, "w")
    node = subprocess.Popen(
        ["dynamixel_handler", "--ros-args", "--params-file", str(ROOT / "config/config_dynamixel_handler.yaml"),
         "-p", f"device_name:={link}", "-p", "latency_timer:=1", "-p", f"init/servo_auto_search.max_id:={N_SERVOS}",
         "-p", f"init/expected_servo_num:={N_SERVOS}", "-p", "init/servo_auto_search.retry_times:=5",
         "-p", "mode_change_interval_sec:=0.0", "-p", "clear_error_interval_sec:=0.0", "-p", "verbose_ratio:=100",
         "-p", "pub_ratio/status:=10", "-p", "pub_ratio/error:=10"],
        stdout=log, stderr=subprocess.STDOUT)
    counts = {"cycles": 0, "commands_sent": 0, "faults_injected": 0, "faults_survived": 0, "lost_commands": 0}
    peak_rss = 0
    end = time.monotonic() + args.minutes * 60
    time.sleep(3.0)
    try:
        while time.monotonic() < end and node.poll() is None:
            fault = FAULTS[counts["cycles"] % len(FAULTS)]
            out = tmp / f"burst{counts['cycles']}.json"
            burst = subprocess.Popen([sys.executable, str(ROOT / "test/support/load_publisher.py"), str(N_SERVOS), "10", "100",
                                      str(args.burst_s), str(out)])
            time.sleep(1.0)
            counts["faults_injected"] += 1
            inject(sim, fault, args.burst_s - 2.0)
            burst.wait(args.burst_s + 30)
            time.sleep(2.0)  # reconnects, retries and the last commands settle
            peak_rss = max(peak_rss, rss_kb(node.pid))
            sent = json.loads(out.read_text())
            counts["commands_sent"] += sent["sent"]
            lost = [i for i, pulses in sent["last_pos"].items() if sim.servo(int(i)).read("goal_position") != pulses]
            counts["lost_commands"] += len(lost)
            alive = node.poll() is None and not sim.vanished
            if alive and not lost:
                counts["faults_survived"] += 1
            print(f"cycle {counts['cycles']:3d}: {fault:15s} {'survived' if alive and not lost else 'FAILED'}"
                  f"{f' (last goal missing on IDs {lost})' if lost else ''}  rss={rss_kb(node.pid) // 1024} MiB", flush=True)
            counts["cycles"] += 1
    finally:
        node.send_signal(signal.SIGINT)
        try:
            code = node.wait(20)
        except subprocess.TimeoutExpired:
            node.kill()
            code = -9
        log.close()
        sim.stop()
    text = log_path.read_text()
    loops = sum(100 for _ in re.finditer(r"ms/loop\(", text))
    periods = [float(m) for m in re.findall(r"time=([0-9.]+)ms/loop", text)]
    writes = sum(1 for e in sim.log if e.name == "sync_write")
    report = {
        "minutes": round(args.minutes, 2), **counts, "loops": loops,
        "loop_ms_first/last/max": [periods[0], periods[-1], max(periods)] if periods else None,
        "commands_refused_warnings": len(re.findall(r"\[WARN\].*(ignored|refused|clamped)", text)),
        "sync_writes_in_last_log_window": writes,
        "reconnects": len(re.findall(r"is back: reconnected", text)),
        "peak_rss_mib": round(peak_rss / 1024, 1), "node_exit_code": code,
        "tracebacks": text.count("Traceback"), "node_log": str(log_path),
    }
    print(json.dumps(report, indent=2))
    ok = code == 0 and counts["faults_survived"] == counts["faults_injected"] and not counts["lost_commands"]
    return 0 if ok else 1


def inject(sim: VirtualBus, fault: str, seconds: float) -> None:
    t_end = time.monotonic() + max(1.0, seconds)
    if fault.startswith("crc"):
        sim.crc_error_rate = 0.01 if fault == "crc_1pct" else 0.1
        time.sleep(max(0.0, t_end - time.monotonic()))
        sim.crc_error_rate = 0.0
    elif fault == "garbage":
        while time.monotonic() < t_end:
            sim.inject_garbage(32)
            time.sleep(0.1)
    elif fault == "truncated":
        while time.monotonic() < t_end:
            sim.truncate_next(1)
            time.sleep(0.1)
    elif fault == "silent_servo":
        sim.set_silent(5, True)
        time.sleep(max(0.0, t_end - time.monotonic()))
        sim.set_silent(5, False)
    elif fault == "hardware_error":
        sim.set_hardware_error(3, 0x04)
        time.sleep(1.0)
        subprocess.run([sys.executable, "-c",
                        "import rclpy,time;from rclpy.node import Node;"
                        "from dynamixel_handler_msgs.msg import DynamixelShortcut as S;"
                        "rclpy.init();n=Node('soak_ce');p=n.create_publisher(S,'/dynamixel/shortcut',10);"
                        "t=time.time()\nwhile p.get_subscription_count()==0 and time.time()-t<5: time.sleep(0.05)\n"
                        "p.publish(S(command='CE',id_list=[3]));time.sleep(0.5)"], check=False, timeout=30)
        time.sleep(max(0.0, t_end - time.monotonic()))
    elif fault == "vanish":
        sim.vanish()
        time.sleep(2.0)
        sim.reappear()
        time.sleep(max(0.0, t_end - time.monotonic()))


if __name__ == "__main__":
    sys.exit(main())
