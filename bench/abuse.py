#!/usr/bin/env python3
"""Hostile cases against the real node on a virtual bus: what one user, script or typo can do.

    source env.sh && python bench/abuse.py            (~2 min; --seconds N per load case)

Cases (each from other processes, through the real topics): a 10,000-entry /dynamixel/commands/all
and a 100,000-entry X bundle; 100 messages/s naming 253 unknown IDs; 100 refused mode changes a
second; a 100 kB shortcut string at 10 Hz; 1,000 + 1,000 command messages a second; 20 servos at
9600 bps at loop_rate 100; SIGINT during a 1000-retry scan and in the loop. The doors added later
have their cases in bench/abuse_<door>.py (services, trajectory, core, timing: see DOORS), run here
with --cases NAME or all by default; the crowd (1,000 clients at each door, abuse_crowd.py) only with
--cases crowd. Per case it prints the
loop rate and the longest gap between two loops (from the simulator's log of the node's reads),
log lines a second, bus watchdog trips, and the node's RSS, threads and file descriptors before
and after. The results go to docs/reliability.md by hand. Not part of the test suite.
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(30 + os.getpid() % 30))

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

X, XL430 = 1020, 1060
PRESENT_POSITION = 132
CONFIG = ROOT / "config" / "config_dynamixel_handler.yaml"
#: the cases of the doors added after the command topics, each in bench/abuse_<name>.py (``run``)
DOORS = {
    "services": "set_torque/move_to/MoveJoints: repeated IDs, hundreds of waiting callers",
    "trajectory": "follow_joint_trajectory: huge goals, a vanishing device; joint_commands at 1 kHz, huge messages",
    "core": "log floods, reboot/add/remove floods, a short bus watchdog, a vanished and returning adapter",
    "timing": "SIGTERM in a mode-change burst, a slow bus after a mode burst",
    "crowd": "1,000 clients (4 processes x 250) at one instant at each door, deep and default queues",
}
#: doors run only when named in --cases (the crowd takes several minutes)
OPT_IN = ("crowd",)


# ---------------------------------------------------------------------------- publisher processes
def publish(kind: str, rate: float, seconds: float) -> None:
    """Runs in a process of its own: publish one kind of hostile traffic at ``rate`` Hz."""
    import rclpy
    from rclpy.node import Node

    from dynamixel_handler_msgs.msg import (
        DxlCommandsAll,
        DxlCommandsX,
        DynamixelControlXPosition,
        DynamixelGoal,
        DynamixelShortcut,
        DynamixelStatus,
    )
    rclpy.init()
    node = Node(f"abuse_{kind}")
    if kind == "huge":
        topic_msgs = [("/dynamixel/commands/all", DxlCommandsAll(goal=DynamixelGoal(
                          id_list=[99] * 10_000, position_deg=[1.0] * 10_000))),
                      ("/dynamixel/commands/x", DxlCommandsX(position_control=DynamixelControlXPosition(
                          id_list=[99] * 100_000, position_deg=[1.0] * 100_000)))]
    elif kind == "bad_ids":
        ids = list(range(0, 253))
        topic_msgs = [("/dynamixel/command/x/position_control",
                       DynamixelControlXPosition(id_list=[i for i in ids if i > 10][:253], position_deg=[0.0] * 242))]
    elif kind == "refused_mode":
        topic_msgs = [("/dynamixel/command/status", DynamixelStatus(id_list=[5], mode=["current"]))]
    elif kind == "long_string":
        topic_msgs = [("/dynamixel/shortcut", DynamixelShortcut(command="Z" * 100_000, id_list=[1]))]
    elif kind == "load_x":
        topic_msgs = [("/dynamixel/command/x/position_control", None)]
    elif kind == "load_goal":
        topic_msgs = [("/dynamixel/command/goal", None)]
    else:
        raise SystemExit(f"unknown kind {kind}")
    types = {"load_x": DynamixelControlXPosition, "load_goal": DynamixelGoal}
    pubs = [node.create_publisher(types.get(kind, type(m)), t, 100) for t, m in topic_msgs]
    end = time.monotonic() + 10
    while any(p.get_subscription_count() == 0 for p in pubs) and time.monotonic() < end:
        time.sleep(0.05)

    def send(k: int) -> None:
        for pub, (_, msg) in zip(pubs, topic_msgs):
            if kind == "load_x":
                msg = DynamixelControlXPosition(id_list=[1, 2], position_deg=[float(k % 90), float(-(k % 90))])
            elif kind == "load_goal":
                msg = DynamixelGoal(id_list=[3, 4], position_deg=[float(k % 45), float(-(k % 45))])
            pub.publish(msg)
    print(paced(send, rate, seconds), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def paced(send, rate: float, seconds: float) -> int:
    """Call ``send(k)`` for k = 0, 1, ... at ``rate`` Hz for ``seconds``, then wait 0.3 s for the last
    messages to leave; returns how many were sent."""
    t0 = next_t = time.monotonic()
    k = 0
    while time.monotonic() - t0 < seconds:
        send(k)
        k += 1
        next_t += 1.0 / rate
        time.sleep(max(0.0, next_t - time.monotonic()))
    time.sleep(0.3)
    return k


def _die_with_parent() -> None:
    """In a child: SIGTERM when this script dies, so no node or publisher outlives it."""
    import ctypes
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def publisher(kind: str, rate: float, seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, __file__, "--publish", kind, str(rate), str(seconds)],
                            stdout=subprocess.PIPE, text=True, preexec_fn=_die_with_parent)


# ---------------------------------------------------------------------------- the node under test
class Node:
    def __init__(self, sim, *params: str, env: dict[str, str] | None = None) -> None:
        args = ["dynamixel_handler", "--ros-args", "--params-file", str(CONFIG)]
        for p in (f"device_name:={sim.start()}", "latency_timer:=1", *params):
            args += ["-p", p]
        env = dict(os.environ, PYTHONUNBUFFERED="1", RCUTILS_LOGGING_BUFFERED_STREAM="0", **(env or {}))
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                     preexec_fn=_die_with_parent)
        self.lines: list[tuple[float, str]] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append((time.monotonic(), line.rstrip("\n")))

    def wait_for(self, text: str, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if any(text in line for _, line in self.lines):
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.05)
        raise SystemExit(f"node: no '{text}'\n" + "\n".join(line for _, line in self.lines[-30:]))

    def resources(self) -> tuple[int, int, int]:
        """RSS [MiB], threads, open file descriptors."""
        pid = self.proc.pid
        status = Path(f"/proc/{pid}/status").read_text().splitlines()
        rss = next(int(s.split()[1]) for s in status if s.startswith("VmRSS:")) // 1024
        threads = next(int(s.split()[1]) for s in status if s.startswith("Threads:"))
        return rss, threads, len(os.listdir(f"/proc/{pid}/fd"))

    def stop(self, sig: int = signal.SIGINT) -> tuple[int, float]:
        """Send ``sig``; the exit code and the time from the signal to the end of the process [s]."""
        t = time.monotonic()
        self.proc.send_signal(sig)
        try:
            code = self.proc.wait(60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = -9
        return code, time.monotonic() - t


def loop_figures(sim, t0: float, t1: float) -> tuple[float, float]:
    """Loop rate [Hz] and longest gap between two loops [ms] in [t0, t1] (sim clock: monotonic)."""
    times = [e.time for e in list(sim.log) if e.name.endswith("sync_read") and t0 <= e.time <= t1
             and e.address <= PRESENT_POSITION < e.address + (e.length or 0)]
    if len(times) < 2:
        return 0.0, float("nan")
    gaps = [b - a for a, b in zip(times, times[1:])]
    return (len(times) - 1) / (times[-1] - times[0]), 1000 * max(gaps)


def velocity_mode(ids: list[int]) -> None:
    """Switch servos to velocity mode (goal 0) through the topic, so that their bus watchdog is armed."""
    subprocess.run([sys.executable, "-c",
                    "import rclpy,time;from rclpy.node import Node;"
                    "from dynamixel_handler_msgs.msg import DynamixelControlXVelocity as V;"
                    "rclpy.init();n=Node('abuse_setup');p=n.create_publisher(V,'/dynamixel/command/x/velocity_control',10);"
                    "t=time.time()\nwhile p.get_subscription_count()==0 and time.time()-t<5: time.sleep(0.05)\n"
                    f"p.publish(V(id_list={ids},velocity_deg_s=[0.0]*{len(ids)}));time.sleep(0.5)"],
                   check=False, timeout=30)
    time.sleep(1.0)


def run_case(name: str, node: Node, sim, pubs: list[tuple[str, float]], seconds: float, rows: list) -> None:
    from common import cpu_seconds
    before = node.resources()
    cpu0 = cpu_seconds(node.proc.pid)
    mark = len(node.lines)
    procs = [publisher(kind, rate, seconds) for kind, rate in pubs]
    time.sleep(1.5)  # the publishers find the node
    t0 = time.monotonic()
    sent = sum(int((p.communicate(timeout=seconds + 60)[0] or "0").split()[-1]) for p in procs)
    t1 = time.monotonic()
    rate, gap = loop_figures(sim, t0, t1 - 0.3)
    lines = [line for t, line in node.lines[mark:] if t0 <= t <= t1]
    trips = sum("bus watchdog tripped" in line or "bus watchdog had tripped" in line for _, line in node.lines[mark:])
    after = node.resources()
    cpu = 100 * (cpu_seconds(node.proc.pid) - cpu0) / (time.monotonic() - t0 + 1.5)
    rows.append((name, sent, rate, gap, len(lines) / (t1 - t0), max((len(line) for line in lines), default=0),
                 trips, before, after))
    print(f"{name:14s} sent={sent:7d} loop={rate:6.1f} Hz gap={gap:7.1f} ms log={len(lines) / (t1 - t0):6.1f} lines/s "
          f"longest={rows[-1][5]:5d} ch trips={trips} cpu={cpu:.0f}% rss/threads/fds {before} -> {after}", flush=True)


def door_main(doc: str | None, run, publish, seconds: float) -> int:
    """The command line of a bench/abuse_<door>.py: ``--seconds`` per case, and ``--publish KIND RATE
    SECONDS`` for the publisher processes it starts of itself."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=seconds, help="length of each case [s]")
    ap.add_argument("--publish", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.publish:
        publish(args.publish[0], float(args.publish[1]), float(args.publish[2]))
        return 0
    from dynamixel_handler.sim import VirtualBus
    run(VirtualBus, args.seconds)
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0, help="length of each load case [s]")
    ap.add_argument("--cases", default="commands,slow,scan," + ",".join(d for d in DOORS if d not in OPT_IN),
                    help="which parts: commands (all command cases), load (the command load alone), slow, scan, "
                         "and the later doors: " + ", ".join(f"{k} ({v})" for k, v in DOORS.items()))
    ap.add_argument("--publish", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.publish:
        publish(args.publish[0], float(args.publish[1]), float(args.publish[2]))
        return 0
    from dynamixel_handler.sim import VirtualBus
    cases = set(args.cases.split(","))
    if "commands" in cases or "load" in cases:
        commands_cases(VirtualBus, args.seconds, load_only="commands" not in cases)
    if "slow" in cases:
        slow_bus(VirtualBus, args.seconds)
    if "scan" in cases:
        scan_exit(VirtualBus)
    for name in DOORS:
        if name in cases:
            importlib.import_module(f"abuse_{name}").run(VirtualBus, args.seconds)
    return 0


def commands_cases(VirtualBus, s: float, load_only: bool = False) -> None:
    rows: list = []
    sim = VirtualBus(servos={1: X, 2: X, 3: X, 4: X, 5: XL430}, wire_timing=False)
    node = Node(sim, "init/servo_auto_search.max_id:=5", "init/expected_servo_num:=5", "verbose_ratio:=300",
                "mode_change_interval_sec:=0.0")
    node.wait_for("handled")
    time.sleep(2.0)
    velocity_mode([3, 4])  # their bus watchdog is armed, so a stalled loop trips it
    time.sleep(1.0)
    t0 = time.monotonic()
    time.sleep(s)
    rate, gap = loop_figures(sim, t0, time.monotonic())
    print(f"{'idle':14s} loop={rate:6.1f} Hz gap={gap:7.1f} ms rss/threads/fds {node.resources()}", flush=True)
    if not load_only:
        run_case("huge_message", node, sim, [("huge", 2.0)], s, rows)
        run_case("bad_ids_100hz", node, sim, [("bad_ids", 100.0)], s, rows)
        run_case("refused_mode", node, sim, [("refused_mode", 100.0)], s, rows)
        run_case("long_string", node, sim, [("long_string", 10.0)], s, rows)
    run_case("load_2x1khz", node, sim, [("load_x", 1000.0), ("load_goal", 1000.0)], 3 * s, rows)
    code, exit_s = node.stop()
    print(f"{'exit (loop)':14s} rc={code} {exit_s:.2f} s", flush=True)
    sim.stop()


def slow_bus(VirtualBus, s: float) -> None:

    # a slow bus: 20 servos at 9600 bps, loop_rate 100, velocity mode (watchdog armed)
    sim = VirtualBus(servos={i: X for i in range(1, 21)}, baudrate=9600)
    node = Node(sim, "baudrate:=9600", "init/servo_auto_search.max_id:=20", "init/expected_servo_num:=20",
                "verbose_ratio:=300")
    node.wait_for("handled", timeout=120)
    velocity_mode(list(range(1, 21)))
    try:
        node.wait_for("cannot be held", timeout=60)
    except SystemExit:  # a node that does not say so
        pass
    settled = len(node.lines)
    time.sleep(3 * s)
    t1 = time.monotonic()
    rate, gap = loop_figures(sim, t1 - 2 * s, t1)
    lines = [line for _, line in node.lines]
    trips = sum("bus watchdog tripped" in line or "had tripped" in line for line in lines)
    later = sum("bus watchdog tripped" in line or "had tripped" in line for line in lines[settled:])
    warned = [line for line in lines if "cannot be held" in line]
    stats = [line for line in lines if "ms/loop(" in line]
    wd = sorted({sim.servo(i).read("bus_watchdog") for i in range(1, 21)})
    print(f"{'9600bps_20':14s} loop={rate:6.2f} Hz gap={gap:7.1f} ms trips={trips} ({later} in the last {3 * s:.0f} s) "
          f"watchdog pulses={wd}")
    print(f"{'':14s} {warned[0].split(': ', 1)[-1] if warned else 'no rate warning'}")
    print(f"{'':14s} stats lines: {len(stats)} in {3 * s:.0f} s; last: {stats[-1].split(': ', 1)[-1] if stats else '-'}")
    code, exit_s = node.stop()
    print(f"{'exit (9600)':14s} rc={code} {exit_s:.2f} s", flush=True)
    sim.stop()


def scan_exit(VirtualBus) -> None:

    # SIGINT during a long start-up scan
    sim = VirtualBus(servos={1: X, 2: X}, wire_timing=False)
    node = Node(sim, "init/servo_auto_search.max_id:=3", "init/expected_servo_num:=3",
                "init/servo_auto_search.retry_times:=1000")
    node.wait_for("scan 3/1001")
    code, exit_s = node.stop()
    print(f"{'exit (scan)':14s} rc={code} {exit_s:.2f} s", flush=True)
    sim.stop()


if __name__ == "__main__":
    sys.exit(main())
