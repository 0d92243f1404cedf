"""The services and the MoveJoints action under abuse, against the real node on a virtual bus
(``abuse.py`` runs it as its ``services`` part; or on its own:
``source env.sh && python -c 'import sys; sys.path[:0]=["bench"]; import abuse, abuse_services;
from dynamixel_handler.sim import VirtualBus; abuse_services.run(VirtualBus, 5)'``).

Cases, each through real rclpy clients of this process while two servos in velocity mode have
their bus watchdog armed (a stalled loop trips it):

- ``torque_dup``: ``set_torque`` naming ID 1 10,000 times (and 1,000 times);
- ``move_to_200``: 200 concurrent ``move_to`` calls with ``wait`` and a 3 s timeout, on a move
  that cannot arrive in time;
- ``move_joints_100``: 100 ``MoveJoints`` goals sent at once.

Per case: answers received / sent, their latency (median / longest), how they ended, the longest
loop gap, log lines a second per cause, watchdog trips, the node's CPU and RSS before / after.
"""
from __future__ import annotations

import re
import statistics
import threading
import time
from collections import Counter

import abuse

CASE_LIMIT_S = 30.0  # a case stops waiting for answers after this long (old code never answered some)


class Client:
    """An rclpy node of this process spun on a thread of its own."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node("abuse_services", context=self.context)
        self.qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.running = True
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.running:
            with self.lock:
                self.executor.spin_once(timeout_sec=0.01)

    def close(self) -> None:
        import rclpy
        self.running = False
        self.thread.join(2)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def _causes(lines: list[str], seconds: float) -> str:
    """Log lines a second per cause (the text after the logger, numbers masked), the top three."""
    counts = Counter(re.sub(r"\d+(\.\d+)?", "#", line.split("]: ", 1)[-1])[:48] for line in lines)
    return ", ".join(f"{n / seconds:.1f}/s '{cause}'" for cause, n in counts.most_common(3)) or "none"


def _report(name: str, node: abuse.Node, sim, t0: float, cpu0: float, before, mark: int, sent: int,
            latencies: list[float], ends: Counter) -> None:
    from common import cpu_seconds
    t1 = time.monotonic()
    _, gap = abuse.loop_figures(sim, t0, t1)
    lines = [line for t, line in node.lines[mark:] if t0 <= t <= t1]
    trips = sum("bus watchdog tripped" in line or "bus watchdog had tripped" in line for _, line in node.lines[mark:])
    cpu_s = cpu_seconds(node.proc.pid) - cpu0
    cpu = 100 * cpu_s / (t1 - t0)
    lat = (f"latency median {1000 * statistics.median(latencies):.0f} ms, longest {1000 * max(latencies):.0f} ms"
           if latencies else "no answer")
    print(f"{name:16s} answers {len(latencies)}/{sent} ({lat}); ends {dict(ends)}; loop gap {gap:.1f} ms; "
          f"trips {trips}; log {len(lines) / (t1 - t0):.1f} lines/s ({_causes(lines, t1 - t0)}); "
          f"cpu {cpu:.0f}% of {t1 - t0:.1f} s ({cpu_s:.2f} s); "
          f"rss/threads/fds {before} -> {node.resources()}", flush=True)


def _wait_all(futures: list, sent_at: list[float], done_at: dict[int, float], limit_s: float) -> None:
    end = time.monotonic() + limit_s
    while time.monotonic() < end and len(done_at) < len(futures):
        now = time.monotonic()
        for k, f in enumerate(futures):
            if k not in done_at and f.done():
                done_at[k] = now - sent_at[k]
        time.sleep(0.005)


def torque_dup(client: Client, node: abuse.Node, sim, count: int) -> None:
    from common import cpu_seconds

    from dynamixel_handler_msgs.srv import SetTorque
    with client.lock:
        cli = client.node.create_client(SetTorque, "/dynamixel/set_torque", qos_profile=client.qos)
    cli.wait_for_service(timeout_sec=10)
    before, cpu0, mark = node.resources(), cpu_seconds(node.proc.pid), len(node.lines)
    t0 = time.monotonic()
    fut = cli.call_async(SetTorque.Request(ids=[1] * count, enable=False))
    done: dict[int, float] = {}
    _wait_all([fut], [t0], done, CASE_LIMIT_S)
    time.sleep(1.0)  # the loops after it, for their gap and trips
    ends = Counter(("refused" if not fut.result().success else "done") if fut.done() else "none" for _ in [0])
    _report(f"torque_dup_{count}", node, sim, t0, cpu0, before, mark, 1, list(done.values()), ends)
    with client.lock:
        client.node.destroy_client(cli)


def move_to_many(client: Client, node: abuse.Node, sim, count: int) -> None:
    from common import cpu_seconds

    from dynamixel_handler_msgs.srv import MoveTo, SetTorque
    with client.lock:
        cli = client.node.create_client(MoveTo, "/dynamixel/move_to", qos_profile=client.qos)
        torque = client.node.create_client(SetTorque, "/dynamixel/set_torque", qos_profile=client.qos)
    cli.wait_for_service(timeout_sec=10)
    torque.wait_for_service(timeout_sec=10)
    on = torque.call_async(SetTorque.Request(ids=[1], enable=True))
    _wait_all([on], [time.monotonic()], {}, 10)
    before, cpu0, mark = node.resources(), cpu_seconds(node.proc.pid), len(node.lines)
    t0 = time.monotonic()
    sent_at, futures = [], []
    for k in range(count):  # a slow move of 170 deg cannot arrive within 3 s
        sent_at.append(time.monotonic())
        futures.append(cli.call_async(MoveTo.Request(ids=[1], positions_deg=[170.0 if k % 2 else -170.0],
                                                     profile_vel_deg_s=10.0, wait=True, timeout_s=3.0)))
    done: dict[int, float] = {}
    _wait_all(futures, sent_at, done, CASE_LIMIT_S)
    ends = Counter(f.result().message.split(" ")[0].rstrip(":") if f.done() else "none" for f in futures)
    _report(f"move_to_{count}", node, sim, t0, cpu0, before, mark, count, list(done.values()), ends)
    with client.lock:
        client.node.destroy_client(cli)
        client.node.destroy_client(torque)


def move_joints_many(client: Client, node: abuse.Node, sim, count: int) -> None:
    from common import cpu_seconds
    from rclpy.action import ActionClient

    from dynamixel_handler_msgs.action import MoveJoints
    with client.lock:
        cli = ActionClient(client.node, MoveJoints, "/dynamixel/move_joints", goal_service_qos_profile=client.qos,
                           result_service_qos_profile=client.qos, cancel_service_qos_profile=client.qos)
    cli.wait_for_server(timeout_sec=10)
    before, cpu0, mark = node.resources(), cpu_seconds(node.proc.pid), len(node.lines)
    t0 = time.monotonic()
    sent_at, goals = [], []
    for k in range(count):
        sent_at.append(time.monotonic())
        with client.lock:  # rclpy's ActionClient drops an answer taken before the future is kept
            goals.append(cli.send_goal_async(MoveJoints.Goal(ids=[2], positions_deg=[float(k % 40)],
                                                             tolerance_deg=1.0, timeout_s=5.0)))
    done: dict[int, float] = {}
    _wait_all(goals, sent_at, done, 20.0)
    accepted = [g.result() for g in goals if g.done() and g.result().accepted]
    with client.lock:
        results = [h.get_result_async() for h in accepted]
    result_done: dict[int, float] = {}
    _wait_all(results, [t0] * len(results), result_done, CASE_LIMIT_S)
    ends = Counter((r.result().result.message.split(" ")[0].rstrip(":") if r.done() else "none") for r in results)
    ends["goal responses"] = len(done)
    _report(f"move_joints_{count}", node, sim, t0, cpu0, before, mark, count, list(done.values()), ends)
    after_goal = node.resources()
    print(f"{'':16s} results {len(result_done)}/{len(accepted)} accepted goals; rss/threads/fds after the goals "
          f"ended {after_goal}", flush=True)


def run(VirtualBus, seconds: float) -> None:
    sim = VirtualBus(servos={1: abuse.X, 2: abuse.X, 3: abuse.X, 4: abuse.X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=4", "init/expected_servo_num:=4", "verbose_ratio:=300")
    node.wait_for("handled")
    time.sleep(2.0)
    abuse.velocity_mode([3, 4])  # their bus watchdog is armed, so a stalled loop trips it
    from common import cpu_seconds
    t0, cpu0 = time.monotonic(), cpu_seconds(node.proc.pid)
    time.sleep(seconds)
    rate, gap = abuse.loop_figures(sim, t0, time.monotonic())
    cpu = 100 * (cpu_seconds(node.proc.pid) - cpu0) / (time.monotonic() - t0)
    print(f"{'idle':16s} loop {rate:.1f} Hz, gap {gap:.1f} ms; cpu {cpu:.0f}%; rss/threads/fds {node.resources()}",
          flush=True)
    client = Client()
    try:
        torque_dup(client, node, sim, 10_000)
        torque_dup(client, node, sim, 1_000)
        move_to_many(client, node, sim, 200)
        time.sleep(min(seconds, 2.0))
        move_joints_many(client, node, sim, 100)
    finally:
        client.close()
        code, exit_s = node.stop()
        print(f"{'exit':16s} rc={code} {exit_s:.2f} s", flush=True)
        sim.stop()
