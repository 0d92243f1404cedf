"""Run the real node in its own process on a virtual bus and measure it from the outside.

The bench process holds the virtual bus (so its instruction log and ``time.monotonic()`` are at
hand) and a small rclpy node that plays a robot controller: for every ``/dynamixel/states``
message it receives it publishes one ``/dynamixel/commands/x`` with a new goal position for every
servo (position_control, the servos' mode already). ``/dynamixel/debug`` is subscribed too so both
program-facing topics are really delivered. Subscriptions are raw (no deserialisation) to keep
the bench's own CPU out of the way.

Measured, over a window after a warm-up:
- loop rate, mean and p99 loop period: from the times at which the bus received the loop's Sync
  Read of the present items (the bus log), cross-checked with the count of states messages;
- CPU: user + system time of the node process (/proc/<pid>/stat) over the window, in % of one core;
- command-to-wire latency: ``time.monotonic()`` just before ``publish()`` -> log time of the first
  Sync Write of Goal Position that carries this command's value (or a newer one: the loop always
  writes the latest command). The goal of command k is ``1024 + k % 2000`` pulses, so a write tells
  which command it carries.
At ``loop_rate`` 100 the controller waits a random 0..0.9 loop periods after each states message
before it publishes, so commands reach the node at every phase of its loop (the worst case of the
latency target included); running flat out it publishes at once.
"""
from __future__ import annotations

import array
import bisect
import ctypes
import os
import queue
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from common import Periods, cpu_seconds, machine_cpu_seconds
from wire import GOAL_ADDRESS, PRESENT_ADDRESS

ROOT = Path(__file__).resolve().parent.parent
SHIPPED_CONFIG = ROOT / "config" / "config_dynamixel_handler.yaml"
SYNC_READS = (0x82, 0x8A)
SYNC_WRITE = 0x83
GOAL_BASE, GOAL_CYCLE = 1024, 2000
X_DEG_PER_PULSE, X_ZERO = 360.0 / 4096.0, 2048


def node_params(device: str, n: int, baudrate: int, latency_timer_ms: int, loop_rate: int, fast_read: bool) -> str:
    """YAML overrides on top of the shipped config: the 3 present items every loop, the other
    present items once at start, the other groups rarely (prime ratios so they seldom meet)."""
    return f"""/**:
  ros__parameters:
    device_name: {device}
    baudrate: {baudrate}
    latency_timer: {latency_timer_ms}
    loop_rate: {loop_rate}
    init/servo_auto_search: {{min_id: 1, max_id: {n}, retry_times: 2}}
    init/expected_servo_num: {n}
    method/fast_read: {'true' if fast_read else 'false'}
    pub_ratio/present: {{pwm: 0, current: 1, velocity: 1, position: 1, velocity_trajectory: 0,
                         position_trajectory: 0, input_voltage: 0, temperature: 0}}
    pub_ratio/status: 1009
    pub_ratio/goal: 1013
    pub_ratio/gain: 0
    pub_ratio/limit: 0
    pub_ratio/error: 1019
    pub_ratio/extra: {{dynamic_items: 1021, static_items: 0}}
"""


def _die_with_parent() -> None:
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


@dataclass
class NodeResult:
    rate_hz: float = float("nan")           # sync reads of the present items per second
    states_hz: float = float("nan")         # /dynamixel/states messages received per second
    mean_s: float = float("nan")
    p99_s: float = float("nan")
    cpu_percent: float = float("nan")
    bench_cpu_percent: float = float("nan")  # the bench process (controller), plus the virtual bus process
    others_cpu_percent: float = float("nan")  # every other process on the machine, in % of one core
    startup_s: float = float("nan")          # process start -> first /dynamixel/states
    latency_mean_s: float = float("nan")
    latency_p99_s: float = float("nan")
    latency_max_s: float = float("nan")
    commands: int = 0
    unmatched: int = 0
    error: str = ""
    log_tail: list[str] = field(default_factory=list)


class Controller:
    """The bench's rclpy node: counts state messages and answers each with a goal command."""

    def __init__(self, command: str = "bundle") -> None:
        """``command``: "bundle" = /dynamixel/commands/x (DxlCommandsX.position_control), "control" =
        /dynamixel/command/x/position_control (DynamixelControlXPosition), "none" = no commands."""
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import QoSProfile

        from dynamixel_handler_msgs.msg import DxlCommandsX, DxlStates, DynamixelControlXPosition, DynamixelDebug

        self._rclpy = rclpy
        self.node = Node("dynamixel_handler_bench")
        qos = QoSProfile(depth=10)
        self.command = command
        if command == "control":
            self._msg_type, topic = DynamixelControlXPosition, "/dynamixel/command/x/position_control"
        else:
            self._msg_type, topic = DxlCommandsX, "/dynamixel/commands/x"
        self.pub = self.node.create_publisher(self._msg_type, topic, qos)
        self.node.create_subscription(DxlStates, "/dynamixel/states", self._on_states, qos, raw=True)
        self.node.create_subscription(DynamixelDebug, "/dynamixel/debug", self._on_debug, qos, raw=True)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.states_times: list[float] = []
        self.debug_count = 0
        self.sent: list[tuple[float, int]] = []
        self.ids: list[int] = []
        self.commanding = False
        self.delay_max_s = 0.0
        self._seq = 0
        self._msg = None
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._spin = True
        self._threads = [threading.Thread(target=self._spin_loop, daemon=True, name="bench-spin"),
                         threading.Thread(target=self._delayed_publisher, daemon=True, name="bench-publish")]
        for t in self._threads:
            t.start()

    def _spin_loop(self) -> None:
        while self._spin:
            self.executor.spin_once(timeout_sec=0.05)

    def reset(self, ids: list[int], delay_max_s: float) -> None:
        self.ids = list(ids)
        self.delay_max_s = delay_max_s
        msg = self._msg_type()
        self._target = msg if self.command == "control" else msg.position_control
        self._target.id_list = array.array("H", self.ids)
        self._msg = msg
        self.states_times = []
        self.debug_count = 0
        self.sent = []
        self.commanding = False

    def _on_states(self, _raw: bytes) -> None:
        now = time.monotonic()
        self.states_times.append(now)
        if not self.commanding or self.command == "none":
            return
        if self.delay_max_s > 0:
            self._queue.put(now)
        else:
            self._publish()

    def _on_debug(self, _raw: bytes) -> None:
        self.debug_count += 1

    def _delayed_publisher(self) -> None:
        while self._spin:
            try:
                self._queue.get(timeout=0.1)
            except queue.Empty:
                continue
            time.sleep(random.uniform(0.0, self.delay_max_s))
            while not self._queue.empty():  # states that arrived meanwhile: one command covers them
                self._queue.get_nowait()
            if self.commanding:
                self._publish()

    def _publish(self) -> None:
        seq = self._seq
        self._seq += 1
        pulse = GOAL_BASE + seq % GOAL_CYCLE
        deg = (pulse - X_ZERO) * X_DEG_PER_PULSE
        self._target.position_deg = array.array("d", [deg] * len(self.ids))
        t = time.monotonic()
        self.pub.publish(self._msg)
        self.sent.append((t, seq))

    def matched(self) -> bool:
        return self.pub.get_subscription_count() > 0

    def close(self) -> None:
        self._spin = False
        for t in self._threads:
            t.join(1.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()


def command_latencies(sent: list[tuple[float, int]], writes: list[tuple[float, int]]) -> tuple[np.ndarray, int]:
    """Per command: time until the first goal write carrying it or a newer command; and how many
    commands never reached the wire."""
    times = [t for t, _ in writes]
    out, unmatched = [], 0
    for t_pub, seq in sent:
        k = bisect.bisect_left(times, t_pub)
        found = None
        while k < len(writes) and writes[k][0] - t_pub < 1.0:
            if (writes[k][1] - seq) % GOAL_CYCLE < GOAL_CYCLE // 2:
                found = writes[k][0] - t_pub
                break
            k += 1
        if found is None:
            unmatched += 1
        else:
            out.append(found)
    return np.asarray(out), unmatched


def measure_node(sim, controller: Controller, n: int, baudrate: int, latency_s: float, loop_rate: int,
                 fast_read: bool, window_s: float, warmup_s: float = 0.4, start_timeout_s: float = 40.0,
                 tree: Path = ROOT) -> NodeResult:
    """Start the node on ``sim``, let it settle, measure for ``window_s``, stop it. ``tree``: the
    source tree whose ``dynamixel_handler`` package the node runs (another revision for an A/B)."""
    result = NodeResult()
    ids = list(range(1, n + 1))
    latency_timer = max(1, int(round(latency_s * 1000)))
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", prefix="dxl_bench_", delete=False) as handle:
        handle.write(node_params(sim.path, n, baudrate, latency_timer, loop_rate, fast_read))
        params_file = handle.name
    cmd = [sys.executable, "-m", "dynamixel_handler.ros.node", "--ros-args",
           "--params-file", str(SHIPPED_CONFIG), "--params-file", params_file]
    env = dict(os.environ, PYTHONUNBUFFERED="1", RCUTILS_LOGGING_BUFFERED_STREAM="0")
    controller.reset(ids, 0.9 / loop_rate if loop_rate <= 200 else 0.0)
    lines: list[str] = []
    started = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            cwd=str(tree), preexec_fn=_die_with_parent)
    reader = threading.Thread(target=lambda: lines.extend(line.rstrip() for line in proc.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + start_timeout_s
        while not (controller.states_times and (controller.matched() or controller.command == "none")):
            if proc.poll() is not None or time.monotonic() > deadline:
                result.error = "node did not start" if proc.poll() is not None else "no states in time"
                result.log_tail = lines[-15:]
                return result
            time.sleep(0.05)
        result.startup_s = time.monotonic() - started
        controller.commanding = True
        time.sleep(warmup_s)
        t0 = time.monotonic()
        bench_pids = [os.getpid(), *([sim.pid] if getattr(sim, "pid", None) else [])]
        cpu0, bench0, all0 = cpu_seconds(proc.pid), sum(map(cpu_seconds, bench_pids)), machine_cpu_seconds()
        states0 = len(controller.states_times)
        time.sleep(window_s)
        t1 = time.monotonic()
        cpu1, bench1, all1 = cpu_seconds(proc.pid), sum(map(cpu_seconds, bench_pids)), machine_cpu_seconds()
        states1 = len(controller.states_times)
        controller.commanding = False
        time.sleep(0.2)  # the last commands of the window reach the wire
        log = sim.log
    finally:
        controller.commanding = False
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        os.unlink(params_file)
    window = t1 - t0
    reads = [e.time for e in log if e.instruction in SYNC_READS and e.address == PRESENT_ADDRESS and t0 <= e.time <= t1]
    periods = Periods.of(reads, window)
    result.rate_hz, result.mean_s, result.p99_s = periods.rate_hz, periods.mean_s, periods.p99_s
    result.states_hz = (states1 - states0) / window
    result.cpu_percent = 100.0 * (cpu1 - cpu0) / window
    result.bench_cpu_percent = 100.0 * (bench1 - bench0) / window
    result.others_cpu_percent = 100.0 * ((all1 - all0) - (cpu1 - cpu0) - (bench1 - bench0)) / window
    writes = [(e.time, int.from_bytes(e.params[5:9], "little") - GOAL_BASE) for e in log
              if e.instruction == SYNC_WRITE and e.address == GOAL_ADDRESS and len(e.params) >= 9 and e.time >= t0]
    sent = [(t, s % GOAL_CYCLE) for t, s in controller.sent if t0 <= t <= t1]
    lat, result.unmatched = command_latencies(sent, writes)
    result.commands = len(sent)
    if len(lat):
        result.latency_mean_s = float(lat.mean())
        result.latency_p99_s = float(np.percentile(lat, 99))
        result.latency_max_s = float(lat.max())
    result.log_tail = lines[-15:]
    if not reads:
        result.error = "no loop seen on the bus"
    return result
