"""CPU cost of one loop, part by part, measured in-process with thread CPU clocks.

    source env.sh && python bench/profile_step.py [--n 12] [--baud 1000000]
                                      [--latency-ms 0] [--fast] [--seconds 3] [--cprofile]
                                      [--tracemalloc]

The node object is built exactly as ``ros2 run`` builds it (same parameters as ``bench_loop.py``),
but its loop body runs here, flat out, in this thread: ``Handler.step()``, publishing and the
step hooks, with one ``/dynamixel/commands/x`` goal per loop published by a controller node in this
process and taken by the node's command intake at the start of the step, as in the real loop. Every part is wrapped in a
timer that reads ``time.thread_time()`` (CPU of this thread only: immune to what else the machine
runs) and ``time.perf_counter()``; nested parts are counted exclusively. The virtual bus runs in
this process on a real-time thread; subscribers in this process make DDS really deliver.

``DYNAMIXEL_HANDLER_FAST_PATH`` chooses the node's fast paths as for the node (``ros/fastpath.py``):
``raw_publish,detached_intake`` measures the loop without the raw CDR intake,
``raw_intake,detached_intake`` without raw CDR publishing. The detached intake is needed here (the
node's subscriptions are taken by this loop, no executor spins the node).
"""
from __future__ import annotations

import argparse
import collections
import cProfile
import functools
import os
import pstats
import sys
import tempfile
import threading
import time
import tracemalloc

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_loop import X_MODEL  # noqa: E402  (also claims the ROS domain before rclpy starts)
from common import coarse_physics, hardware_priority  # noqa: E402
from node_run import GOAL_BASE, GOAL_CYCLE, SHIPPED_CONFIG, X_DEG_PER_PULSE, X_ZERO, node_params  # noqa: E402

CONTROLLER = "controller: publish the command (not the node; subtracted)"
WAIT = "sync read: wait, syscalls, reply parsing (+ bus wait)"


class PartTimer:
    """Exclusive CPU and wall time per label, for wrapped calls on this thread."""

    def __init__(self) -> None:
        self.cpu: collections.Counter = collections.Counter()
        self.wall: collections.Counter = collections.Counter()
        self.calls: collections.Counter = collections.Counter()
        self._stack: list[list] = []  # [label, cpu0, wall0, child_cpu, child_wall]
        self.thread = threading.get_ident()

    def wrap(self, label: str, fn):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            if threading.get_ident() != self.thread:
                return fn(*args, **kwargs)
            frame = [label, time.thread_time(), time.perf_counter(), 0.0, 0.0]
            self._stack.append(frame)
            try:
                return fn(*args, **kwargs)
            finally:
                self._stack.pop()
                cpu = time.thread_time() - frame[1]
                wall = time.perf_counter() - frame[2]
                self.cpu[label] += cpu - frame[3]
                self.wall[label] += wall - frame[4]
                self.calls[label] += 1
                if self._stack:
                    self._stack[-1][3] += cpu
                    self._stack[-1][4] += wall
        return timed

    def patch(self, owner, name: str, label: str) -> None:
        setattr(owner, name, self.wrap(label, getattr(owner, name)))


def _owners(diff: list) -> dict[str, int]:
    """Memory growth by owner: the node's code, the virtual bus (its instruction log), the rest
    (rclpy, DDS queues of the listeners in this process, the interpreter)."""
    out = {"node": 0, "virtual bus": 0, "rclpy and the rest": 0}
    for stat in diff:
        name = stat.traceback[0].filename.replace(os.sep, "/")
        if "/dynamixel_handler/sim/" in name or name.endswith("/protocol/servo.py"):
            out["virtual bus"] += stat.size_diff
        elif "/dynamixel_handler/" in name:
            out["node"] += stat.size_diff
        else:
            out["rclpy and the rest"] += stat.size_diff
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--baud", type=int, default=1_000_000)
    ap.add_argument("--latency-ms", type=float, default=0.0)
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--cprofile", action="store_true", help="also print the top functions by own time")
    ap.add_argument("--tracemalloc", action="store_true",
                    help="also measure the memory still held per loop (growth) and its top sources")
    ap.add_argument("--sort", default="tottime", help="cProfile order: tottime (own time) or cumulative")
    ap.add_argument("--top", type=int, default=25, help="cProfile rows shown")
    ap.add_argument("--detail", action="store_true",
                    help="split 'step: the rest' into its parts (each timer costs ~1-2 us more)")
    ap.add_argument("--cpu-clock", action="store_true",
                    help="cProfile counts this thread's CPU time (waits for the bus drop out; each "
                         "call costs more to time, so the figures are inflated more than with the wall clock)")
    a = ap.parse_args(argv)

    from dynamixel_handler.sim import VirtualBus
    sim = VirtualBus(servos={i: X_MODEL for i in range(1, a.n + 1)}, baudrate=a.baud, latency_s=a.latency_ms / 1000)
    path = sim.start()
    print(hardware_priority() + ", " + coarse_physics())
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as handle:
        handle.write(node_params(path, a.n, a.baud, max(1, int(round(a.latency_ms))), 2000, a.fast))
        params = handle.name

    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.publisher import Publisher

    from dynamixel_handler import units
    from dynamixel_handler.bus import GroupRead
    from dynamixel_handler.ros import convert
    from dynamixel_handler.ros import node as node_module
    from dynamixel_handler.ros.cdr import Codec
    from dynamixel_handler_msgs.msg import DxlCommandsX, DxlStates, DynamixelDebug, DynamixelPresent

    rclpy.init(args=["--ros-args", "--params-file", str(SHIPPED_CONFIG), "--params-file", params])
    node = node_module.DynamixelHandlerNode()
    if not node.fast.detached_intake:
        print("profile_step.py needs the detached intake (DYNAMIXEL_HANDLER_FAST_PATH must allow detached_intake)")
        return 2
    listener = Node("dynamixel_handler_bench_listener")
    for typ, topic in ((DxlStates, "/dynamixel/states"), (DynamixelDebug, "/dynamixel/debug"),
                       (DynamixelPresent, "/dynamixel/state/present")):
        listener.create_subscription(typ, topic, lambda _m: None, 10, raw=True)
    controller = listener.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 10)
    executor = SingleThreadedExecutor()
    executor.add_node(listener)
    spinning = True

    def spin() -> None:
        while spinning:
            executor.spin_once(timeout_sec=0.05)
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()

    node.wire.open()
    node.handler.start()
    handler = node.handler
    deadline = time.monotonic() + 5
    while controller.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    ids = list(range(1, a.n + 1))

    t = PartTimer()
    t.patch(handler.intake, "run_queued", "commands: queued requests (validate, units -> pulses, pending)")
    t.patch(handler.writes, "_encode_pending", "goal write: encode")
    t.patch(handler.bus, "prepare_sync_write", "goal write: sync write packet")
    t.patch(handler.bus, "execute", "goal write: sync write send (write syscall)")  # the loop's one instruction
    t.patch(handler.bus, "start_sync_read", "sync read: packet, send")
    t.patch(GroupRead, "result", WAIT)
    t.patch(handler.reads, "store", "decode + store in the servo table")
    t.patch(handler.reads, "plan", "read planning")
    t.patch(handler.recovery, "update_ping", "ping bookkeeping")
    t.patch(handler, "step", "step: the rest")
    if a.detail:
        for part, name, label in ((handler.steps, "prepare", "step: prepare (reconnect, watchdogs, deferred)"),
                                  (handler.reads, "due", "step: items due"),
                                  (handler.writes, "_build_writes", "step: goal write batching"),
                                  (handler.steps, "complete_step", "step: complete (who answered)"),
                                  (handler.reads, "gather", "step: gather replies"),
                                  (handler.steps, "finish_step", "step: finish (store, logs)"),
                                  (handler.steps, "_log_reads", "step: read logs")):
            t.patch(part, name, label)
    for name in ("states", "debug", "present", "status", "goal"):
        t.patch(convert, name, "message building (convert.py)")
    t.patch(units, "pulse_to_unit", "units: pulse -> physical (numpy)")
    controller_publish = functools.partial(Publisher.publish, controller)  # not timed as the node's
    t.patch(Publisher, "publish", "publish (rclpy: Python -> C, serialise, DDS write)")
    from dynamixel_handler.ros import lean, publishers
    for owner, name in ((getattr(lean, "Patcher", None), "encode"), (getattr(publishers, "Frame", None), "run")):
        if owner is not None:  # the bytes kept from loop to loop (absent in older versions of the node)
            t.patch(owner, name, "message encoding (cdr.py)")
    t.patch(Codec, "encode", "message encoding (cdr.py)")
    t.patch(Codec, "to_message", "message encoding (cdr.py)")
    t.patch(Codec, "decode", "command: decode (cdr.py)")
    node.step_hooks = [t.wrap("step hooks (diagnostics, joint_states)", h) for h in node.step_hooks]
    def publish_here(report) -> None:  # the node does this on its publishing thread (outbox.py)
        for publisher, value in node._messages(report, node.handler.table.snapshot()):
            publisher.publish(value)
    publish_all = t.wrap("publish: the rest (_messages)", publish_here)
    take = t.wrap("command: take (intake: take, unpack, checks, queue)", node.intake.poll)
    send = t.wrap(CONTROLLER, controller_publish)
    loop_body = t.wrap("loop: the rest", lambda report: None)

    msg = DxlCommandsX()
    msg.position_control.id_list = ids

    def one_loop(k: int) -> None:
        pulse = GOAL_BASE + k % GOAL_CYCLE
        msg.position_control.position_deg = [(pulse - X_ZERO) * X_DEG_PER_PULSE] * len(ids)
        send(msg)  # the controller's side, not counted
        take()
        report = handler.step()
        publish_all(report)
        for hook in node.step_hooks:
            hook(report)
        loop_body(report)

    for k in range(50):  # warm-up: first loop reads every group
        one_loop(k)
    for counter in (t.cpu, t.wall, t.calls):
        counter.clear()
    profiler = (cProfile.Profile(time.thread_time) if a.cpu_clock else cProfile.Profile()) if a.cprofile else None
    if a.tracemalloc:
        tracemalloc.start(5)
        for k in range(50):  # the allocator's own first-use costs are not growth
            one_loop(k)
        held0, before = tracemalloc.get_traced_memory()[0], tracemalloc.take_snapshot()
    loops, cpu0, wall0 = 0, time.thread_time(), time.perf_counter()
    end = wall0 + a.seconds
    if profiler:
        profiler.enable()
    while time.perf_counter() < end:
        one_loop(loops)
        loops += 1
    if profiler:
        profiler.disable()
    cpu, wall = time.thread_time() - cpu0, time.perf_counter() - wall0
    growth = []
    if a.tracemalloc:
        held = tracemalloc.get_traced_memory()[0]
        growth = [f"tracemalloc: {held - held0:+d} bytes held after {loops} loops = {(held - held0) / loops:+.1f} bytes/loop "
                  "(timings above include tracemalloc's cost); largest growth:"]
        diff = tracemalloc.take_snapshot().compare_to(before, "lineno")
        growth.append("  by owner: " + ", ".join(f"{owner} {size / loops:+.1f} bytes/loop"
                                                  for owner, size in _owners(diff).items()))
        growth += [f"  {stat}" for stat in diff[:8]]
        tracemalloc.stop()
    cpu -= t.cpu.pop(CONTROLLER, 0.0)
    wall -= t.wall.pop(CONTROLLER, 0.0)
    taken = node.intake.taken
    spinning = False
    spinner.join(1)
    handler.shutdown()
    node.wire.close()
    sim.close()
    os.unlink(params)

    print(f"{a.n} servos, {a.baud} bps, latency {a.latency_ms:g} ms, fast_read {a.fast}: {loops} loops in "
          f"{wall:.1f} s = {loops / wall:.0f} loops/s; loop thread CPU {1e6 * cpu / loops:.0f} us/loop, "
          f"wall {1e6 * wall / loops:.0f} us/loop; {taken} commands taken" + (" (cProfile on: slower)" if profiler else ""))
    print(f"{'part':58s} {'CPU us/loop':>11s} {'share':>6s} {'wall us/loop':>12s}")
    total = sum(t.cpu.values())
    for label, value in t.cpu.most_common():
        print(f"{label:58s} {1e6 * value / loops:11.0f} {100 * value / total:5.1f}% {1e6 * t.wall[label] / loops:12.0f}")
    wait = t.wall[WAIT] - t.cpu[WAIT]
    print(f"{'(of which sync read wall not on CPU: bus wait)':58s} {'':11s} {'':6s} {1e6 * wait / loops:12.0f}")
    for line in growth:
        print(line)
    if profiler:
        print()
        pstats.Stats(profiler).sort_stats(a.sort).print_stats(a.top)
    node.destroy_node()
    listener.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
