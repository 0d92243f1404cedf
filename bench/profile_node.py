"""Where the node's time goes: py-spy samples of the real node process under the benchmark load.

    source env.sh && .venv/bin/pip install py-spy   # once
    python bench/profile_node.py [--n 12] [--baud 1000000] [--latency-ms 0] [--loop-rate 100] [--fast]
                                 [--seconds 6] [--flame out.svg]

Same set-up as ``bench_loop.py`` (virtual bus with wire timing in this process, the controller
answering every /dynamixel/states with a /dynamixel/commands/x goal), then ``py-spy record`` of the
node process, idle samples included, per thread. Each sample of a thread is put in the first
bucket its stack matches (innermost frame first), so the table says which share of that thread's
wall time went to waiting for the bus, to Python work on packets, decoding, units, building
messages, publishing, handling commands, or to sleeping until the next loop.
"""
from __future__ import annotations

import argparse
import collections
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import node_run  # noqa: E402
from bench_loop import X_MODEL  # noqa: E402  (also claims the ROS domain before rclpy starts)
from common import coarse_physics, hardware_priority, raise_priority  # noqa: E402

from dynamixel_handler.sim import VirtualBus  # noqa: E402

#: (bucket, any of these substrings in a frame) checked from the innermost frame outwards
BUCKETS: list[tuple[str, tuple[str, ...]]] = [
    ("serial I/O calls (write, in_waiting, read, flush)", ("serialposix.py", "port_handler.py", "discard_input",
                                                            "SerialPort.write")),
    ("packet build (instruction, CRC)", ("build_instruction", "sync_write_params", "sync_read_params", "crc16",
                                         "stuff (")),
    ("reply parsing (status stream, fast reply)", ("StatusStream", "FastReply", "unstuff")),
    ("sleep (until the next period, or until the replies are due)", ("Event.wait", "Condition.wait")),
    ("publish (rclpy serialisation + DDS)", ("Publisher.publish", "publish (rclpy")),
    ("message building (convert.py)", ("ros/convert.py",)),
    ("units (pulse <-> physical)", ("units.py", "ServoTable.units", "ServoTable.pulses", "ServoTable.known")),
    ("decode + store (ReadPlan.store)", ("store (dynamixel_handler/core/read_plan.py",)),
    ("commands (callbacks, validation, queue)", ("commands/", "command_topics.py", "run_queued (", "core/intake.py")),
    ("pending writes -> sync write", ("_encode_pending", "PendingWrites")),
    ("read planning, ping bookkeeping", ("plan (dynamixel_handler/core/read_plan.py", "update_ping", "due_items", "send_step",
                                         "complete_step")),
    ("bus layer other (stats, locks, reply bookkeeping)", ("bus/core.py", "dummy.py")),
    ("diagnostics / joint states", ("diagnostic", "joint_state")),
    ("executor wait (idle)", ("_wait_for_ready_callbacks", "wait_for_ready_callbacks",
                              "_worker (concurrent/futures/thread.py")),
    ("loop bookkeeping (runner, step)", ("dynamixel_handler/loop/runner.py", "dynamixel_handler/loop/stats.py",
                                         "dynamixel_handler/core/step.py")),
]
#: innermost frames that mean the thread is blocked in C (select / sleep), not running Python
BLOCKED: list[tuple[str, str]] = [
    ("SerialPort.read_until", "bus wait (blocked in select on the port)"),
    ("_pause_before_retry", "retry pause after a failed transaction (dyn_comm/inerval_msec)"),
    ("CommandIntake.wait", "sleep until the next period (woken by a command)"),
]


def bucket_of(frames: list[str]) -> str:
    if frames:
        for key, name in BLOCKED:
            if frames[-1].startswith(key + " "):
                return name
    for frame in reversed(frames):  # innermost first
        for name, keys in BUCKETS:
            if any(k in frame for k in keys):
                return name
    return "other: " + (frames[-1] if frames else "?")


def summarise(raw_path: str) -> dict[str, collections.Counter]:
    """thread -> Counter(bucket -> samples) from py-spy's raw (collapsed) output with --threads."""
    per_thread: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    with open(raw_path) as handle:
        for line in handle:
            stack, _, count = line.rstrip("\n").rpartition(" ")
            if not stack:
                continue
            frames = stack.split(";")
            thread = frames[0]
            name = thread.split('"')[1] if '"' in thread else thread
            per_thread[name][bucket_of(frames[1:])] += int(count)
    return per_thread


def report(per_thread: dict[str, collections.Counter], seconds: float, loops: float) -> str:
    out = []
    for thread, counts in sorted(per_thread.items(), key=lambda kv: -sum(kv[1].values())):
        total = sum(counts.values())
        out.append(f"thread {thread}: {total} samples")
        for name, count in counts.most_common(14):
            per_loop = seconds * count / total / loops * 1e3 if loops else float("nan")
            out.append(f"  {100 * count / total:5.1f} %  {per_loop:6.3f} ms/loop  {name}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--baud", type=int, default=1_000_000)
    ap.add_argument("--latency-ms", type=float, default=0.0)
    ap.add_argument("--loop-rate", type=int, default=100)
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--rate", type=int, default=250, help="py-spy samples per second")
    ap.add_argument("--flame", default=None, help="also write a flame graph (svg)")
    ap.add_argument("--keep", default=None, help="keep py-spy's raw samples in this file")
    a = ap.parse_args(argv)
    spy = shutil.which("py-spy") or os.path.join(os.path.dirname(sys.executable), "py-spy")
    if not os.path.exists(spy):
        print("py-spy is not installed: .venv/bin/pip install py-spy", file=sys.stderr)
        return 2

    import rclpy
    rclpy.init()
    controller = node_run.Controller()
    sim = VirtualBus(servos={i: X_MODEL for i in range(1, a.n + 1)}, baudrate=a.baud, latency_s=a.latency_ms / 1000)
    sim.start()
    print(raise_priority() + ", " + hardware_priority() + ", " + coarse_physics())
    raw = tempfile.mktemp(suffix=".txt", prefix="dxl_pyspy_")
    profiled: dict = {}

    # measure_node starts the node; py-spy attaches once the node answers (the warm-up), then runs
    # for the whole measuring window
    original_popen = node_run.subprocess.Popen

    def popen(*args, **kwargs):
        proc = original_popen(*args, **kwargs)
        profiled["pid"] = proc.pid
        return proc

    def attach() -> None:
        while "pid" not in profiled or not controller.states_times:
            time.sleep(0.05)
        time.sleep(0.5)
        profiled["spy"] = subprocess.run(
            [spy, "record", "--pid", str(profiled["pid"]), "--duration", str(int(a.seconds)), "--rate", str(a.rate),
             "--idle", "--threads", "--format", "raw", "--output", raw, "--nonblocking"],
            capture_output=True, text=True)
        if a.flame:
            subprocess.run([spy, "record", "--pid", str(profiled["pid"]), "--duration", "2", "--rate", str(a.rate),
                            "--threads", "--output", a.flame, "--nonblocking"], capture_output=True, text=True)

    node_run.subprocess.Popen = popen
    spy_thread = threading.Thread(target=attach, daemon=True)
    spy_thread.start()
    try:
        res = node_run.measure_node(sim, controller, a.n, a.baud, a.latency_ms / 1000, a.loop_rate, a.fast,
                                    window_s=a.seconds + (3 if a.flame else 1), warmup_s=0.7)
    finally:
        node_run.subprocess.Popen = original_popen
        spy_thread.join(5)
        controller.close()
        sim.close()
        rclpy.try_shutdown()
    print(f"node: {res.rate_hz:.0f} loops/s, CPU {res.cpu_percent:.0f} % of one core, "
          f"mean period {1e3 * res.mean_s:.2f} ms, p99 {1e3 * res.p99_s:.2f} ms, "
          f"command latency mean {1e3 * res.latency_mean_s:.2f} ms p99 {1e3 * res.latency_p99_s:.2f} ms")
    print("node log (last lines):", *[line[:200] for line in res.log_tail[-6:]], sep="\n  ")
    if res.error:
        print("node run failed:", res.error)
    if not os.path.exists(raw):
        print("py-spy produced no profile:", profiled.get("spy").stderr if profiled.get("spy") else "not run")
        return 1
    print(f"py-spy, {a.seconds:g} s at {a.rate} Hz, idle samples included "
          "(ms/loop = share of the thread's wall time per loop):")
    print(report(summarise(raw), a.seconds, res.rate_hz * a.seconds))
    if a.keep:
        shutil.move(raw, a.keep)
    else:
        os.unlink(raw)
    return 0


if __name__ == "__main__":
    sys.exit(main())
