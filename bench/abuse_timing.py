"""Timing cases of the abuse benchmark: a stop in the middle of a burst of mode changes, and a slow
bus right after one. Run by ``bench/abuse.py`` (``run(VirtualBus, seconds)``) or on its own:

    source env.sh && python bench/abuse_timing.py [--seconds 5]

Cases (the real node on the virtual bus, commands through the real topic):
  mode_exit_*   20 XM430 at 57600 bps; velocity commands for all 20 (20 mode changes queued at
                once), then SIGTERM after 0.1-1.0 s: exit time (signal to process end), exit code,
                and whether every servo was left as term/* say (torque off).
  burst_9600    20 XM430 at 9600 bps, loop_rate 100; velocity commands for all 20, then 3 x seconds
                (at least 15 s): bus watchdog trips (the node's log and the virtual bus's instruction
                log), the longest time an armed servo went without an instruction against its
                watchdog time, loop rate and longest loop gap, RSS before/after, CPU.
"""
from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import abuse  # noqa: E402
from common import cpu_seconds  # noqa: E402

from dynamixel_handler.sim.unaddressed import unaddressed  # noqa: E402

X = abuse.X
IDS = list(range(1, 21))
EXIT_PHASES = (0.1, 0.3, 0.6, 1.0)


def _velocity_command(ids: list[int]) -> subprocess.Popen:
    """Publish one velocity command for ``ids`` (each servo changes to velocity mode) from a process
    of its own; returns once the node's subscription is matched and the message is out."""
    code = ("import rclpy,time,sys;from rclpy.node import Node;"
            "from dynamixel_handler_msgs.msg import DynamixelControlXVelocity as V;"
            "rclpy.init();n=Node('abuse_timing');p=n.create_publisher(V,'/dynamixel/command/x/velocity_control',10);"
            "t=time.time()\nwhile p.get_subscription_count()==0 and time.time()-t<10: time.sleep(0.02)\n"
            f"p.publish(V(id_list={ids},velocity_deg_s=[5.0]*{len(ids)}));print('sent',flush=True);time.sleep(2)")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            preexec_fn=abuse._die_with_parent)
    assert proc.stdout is not None
    proc.stdout.readline()  # "sent"
    return proc



def _causes(lines: list[str], seconds: float, top: int = 3) -> str:
    """Log lines a second per cause (the message with its numbers masked), the most frequent first."""
    counts: dict[str, int] = {}
    for line in lines:
        cause = re.sub(r"\d+(\.\d+)?", "#", line.split("]: ", 1)[-1])[:48]
        counts[cause] = counts.get(cause, 0) + 1
    ranked = sorted(counts.items(), key=lambda kv: -kv[1])[:top]
    return "; ".join(f"{n / seconds:.2f}/s '{cause}'" for cause, n in ranked) or "-"


def _settle(sim, quiet_s: float = 0.3, timeout: float = 5.0) -> None:
    """Wait until the virtual bus has taken the last packets the node sent before it exited (its
    serving thread may lag behind on a loaded machine)."""
    end, count, since = time.monotonic() + timeout, -1, time.monotonic()
    while time.monotonic() < end:
        now_count = len(sim.log)
        if now_count != count:
            count, since = now_count, time.monotonic()
        elif time.monotonic() - since >= quiet_s:
            return
        time.sleep(0.05)


def mode_exit(VirtualBus, after: float) -> None:
    sim = VirtualBus(servos={i: X for i in IDS}, baudrate=57600)
    node = abuse.Node(sim, "baudrate:=57600", "init/servo_auto_search.max_id:=20", "init/expected_servo_num:=20",
                      "verbose_ratio:=0")
    node.wait_for("loop running", timeout=120)
    time.sleep(1.0)
    rss = node.resources()
    pub = _velocity_command(IDS)
    time.sleep(after)
    code, exit_s = node.stop(signal.SIGTERM)
    pub.kill()
    _settle(sim)
    modes = sum(sim.servo(i).read("operating_mode") == 1 for i in IDS)
    torque_on = [i for i in IDS if sim.servo(i).read("torque_enable")]
    moving = [i for i in IDS if sim.servo(i).read("goal_velocity") != 0 and sim.servo(i).read("torque_enable")]
    print(f"{'mode_exit_' + format(after, 'g'):14s} rc={code} exit={exit_s:.2f} s velocity mode {modes}/20 "
          f"torque on {len(torque_on)} moving {len(moving)} rss {rss}", flush=True)
    dropped = [line.split("]: ", 1)[-1] for _, line in node.lines if "not made (dropped)" in line]
    print(f"{'':14s} {dropped[0] if dropped else 'no mode change dropped'}", flush=True)
    sim.stop()


def burst_9600(VirtualBus, seconds: float) -> None:
    sim = VirtualBus(servos={i: X for i in IDS}, baudrate=9600)
    node = abuse.Node(sim, "baudrate:=9600", "init/servo_auto_search.max_id:=20", "init/expected_servo_num:=20",
                      "verbose_ratio:=300")
    node.wait_for("loop running", timeout=180)
    time.sleep(2.0)
    before = node.resources()
    cpu0, t0 = cpu_seconds(node.proc.pid), time.monotonic()
    mark = len(node.lines)
    pub = _velocity_command(IDS)
    span = max(15.0, 3 * seconds)
    time.sleep(span)
    t1 = time.monotonic()
    pub.kill()
    log = sim.log
    gaps = unaddressed(log, IDS, t0, t1)
    rate, gap = abuse.loop_figures(sim, t0, t1)
    lines = [line for _, line in node.lines[mark:]]
    trips = sum("bus watchdog tripped" in line or "had tripped" in line for line in lines)
    after = node.resources()
    cpu = 100 * (cpu_seconds(node.proc.pid) - cpu0) / (time.monotonic() - t0)
    wd = sorted({sim.servo(i).read("bus_watchdog") for i in IDS})
    modes = sum(sim.servo(i).read("operating_mode") == 1 for i in IDS)
    worst_id, worst_s = gaps.worst
    print(f"{'burst_9600':14s} {span:.0f} s after the burst: velocity mode {modes}/20, trips node log={trips} "
          f"servos={gaps.trip_count} "
          f"longest unaddressed (armed)={1000 * worst_s:.0f} ms (ID {worst_id}) watchdog pulses now={wd} "
          f"loop={rate:.2f} Hz gap={gap:.0f} ms log={len(lines) / span:.1f} lines/s cpu={cpu:.0f}% "
          f"rss/threads/fds {before} -> {after}", flush=True)
    print(f"{'':14s} log by cause: {_causes(lines, span)}", flush=True)
    code, exit_s = node.stop(signal.SIGINT)
    print(f"{'exit (9600)':14s} rc={code} {exit_s:.2f} s", flush=True)
    sim.stop()


def run(VirtualBus, seconds: float) -> None:
    for after in EXIT_PHASES:
        mode_exit(VirtualBus, after)
    burst_9600(VirtualBus, seconds)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--cases", default="exit,burst")
    args = ap.parse_args()
    from dynamixel_handler.sim import VirtualBus
    if "exit" in args.cases:
        for after in EXIT_PHASES:
            mode_exit(VirtualBus, after)
    if "burst" in args.cases:
        burst_9600(VirtualBus, args.seconds)
