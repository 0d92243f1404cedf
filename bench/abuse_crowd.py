#!/usr/bin/env python3
"""A crowd at every door: 1,000 clients (4 processes x 250), one request each, sent at the same
instant, against the real node on a virtual bus.

    source env.sh && python bench/abuse_crowd.py [--doors set_torque,move_to,...] [--depths 1000,10]
    (or from bench/abuse.py: ``--cases crowd``)

Doors: ``set_torque`` (torque on for ID 1), ``move_to`` (ID 1 to +-10 deg with ``wait`` and a 3 s
timeout), ``move_joints`` (ID 2, 3 s timeout) and ``follow_joint_trajectory`` (both joints, one
point at 1 s). Each door twice: with deep-queue clients (QoS depth 1000, as docs/robot_integration.md
advises) and with rclpy's default depth (10). Each client process creates its 250 clients, waits
until every server is there, and sends its requests at an instant the parent gives all four.

Per case: answers received / sent (for the actions: goal responses, accepted / rejected, then the
results of the accepted goals), latency median / longest from each request's send and how many came
within the callers' 3 s; in two phases, the clients being made and finding the node (discovery)
and the requests from the send instant until every answer is in: the longest loop gap and the gaps
over 50 ms (from the simulator's log of the node's reads), the CPU and run-queue wait of each of
the node's threads, the simulator's and the client processes' CPU (crowd_probe.py); the node's RSS
/ threads / FDs before, at the peak, AFTER_S after, and what malloc_trim(0) gives back then.
``--nice 0,19`` runs each crowd with the client processes at each nice value; ``--stalls FILE``
has the node write where its threads were whenever a thread of its own woke over 50 ms late;
``--hardware-priority`` runs the simulator's thread at SCHED_FIFO, ``--loop-fifo`` (an experiment)
the node's loop thread, both set from outside (root). The
figures go to docs/reliability.md by hand. Not part of the test suite.
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import abuse  # noqa: E402  (sets the ROS environment of the bench: localhost, a domain of its own)
import crowd_probe  # noqa: E402
from abuse_trajectory import ACTION, JOINTS  # noqa: E402

PROCESSES, CLIENTS = 4, 250
DOORS = ("set_torque", "move_to", "move_joints", "follow_joint_trajectory")
DEPTHS = (1000, 10)
TIMEOUT_S = 3.0     # the callers' own timeout (move_to, move_joints)
LIMIT_S = 60.0      # a client process stops waiting for answers after this long
AFTER_S = 5.0       # the node's RSS is read again this long after the clients have gone
TRIM = f"/tmp/dxl_crowd_trim_{os.getpid()}"  # the node's answer to "trim now" (bench/thread_names)


# ---------------------------------------------------------------------------- a client process
class _Door:
    """One kind of client: how it is made, how a request is sent and what its answer says."""

    def __init__(self, node, door: str, depth: int) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        self.node, self.door = node, door
        self.qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
        self.action = door in ("move_joints", "follow_joint_trajectory")

    def make(self):
        from rclpy.action import ActionClient
        if self.door == "set_torque":
            from dynamixel_handler_msgs.srv import SetTorque
            return self.node.create_client(SetTorque, "/dynamixel/set_torque", qos_profile=self.qos)
        if self.door == "move_to":
            from dynamixel_handler_msgs.srv import MoveTo
            return self.node.create_client(MoveTo, "/dynamixel/move_to", qos_profile=self.qos)
        if self.door == "move_joints":
            from dynamixel_handler_msgs.action import MoveJoints
            return ActionClient(self.node, MoveJoints, "/dynamixel/move_joints", goal_service_qos_profile=self.qos,
                                result_service_qos_profile=self.qos, cancel_service_qos_profile=self.qos)
        from control_msgs.action import FollowJointTrajectory
        return ActionClient(self.node, FollowJointTrajectory, ACTION, goal_service_qos_profile=self.qos,
                            result_service_qos_profile=self.qos, cancel_service_qos_profile=self.qos)

    def ready(self, client, timeout: float) -> bool:
        return bool(client.wait_for_server(timeout) if self.action else client.wait_for_service(timeout))

    def send(self, client, k: int):
        if self.door == "set_torque":
            from dynamixel_handler_msgs.srv import SetTorque
            return client.call_async(SetTorque.Request(ids=[1], enable=True))
        if self.door == "move_to":
            from dynamixel_handler_msgs.srv import MoveTo
            return client.call_async(MoveTo.Request(ids=[1], positions_deg=[10.0 if k % 2 else -10.0], wait=True,
                                                    timeout_s=TIMEOUT_S))
        if self.door == "move_joints":
            from dynamixel_handler_msgs.action import MoveJoints
            return client.send_goal_async(MoveJoints.Goal(ids=[2], positions_deg=[float(k % 40)], tolerance_deg=1.0,
                                                          timeout_s=TIMEOUT_S))
        from builtin_interfaces.msg import Duration
        from control_msgs.action import FollowJointTrajectory
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
        a = 0.1 * (k % 10)
        point = JointTrajectoryPoint(positions=[a, -a], time_from_start=Duration(sec=1))
        return client.send_goal_async(FollowJointTrajectory.Goal(
            trajectory=JointTrajectory(joint_names=["pan", "tilt"], points=[point])))

    def end(self, answer) -> str:
        """How a service answer or an action result ended (its first word, or the status)."""
        if self.door == "set_torque":
            return "done" if answer.success else "refused"
        if self.door == "move_to":
            return answer.message.split(" ")[0].rstrip(":") or ("done" if answer.success else "refused")
        if self.door == "move_joints":
            return answer.result.message.split(" ")[0].rstrip(":")
        return f"status {answer.status} code {answer.result.error_code}"


def clients(spec: str, count: int) -> None:
    """Runs in a process of its own: ``count`` clients of ``door/depth``; 'ready' when every server
    is found, then the send instant (wall clock) from stdin; prints one JSON line of figures."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    door_name, depth = spec.split("/")
    rclpy.init()
    node = Node(f"crowd_{door_name}_{int(time.time() * 1000) % 100000}")
    door = _Door(node, door_name, int(depth))
    made = [door.make() for _ in range(count)]
    found = sum(door.ready(c, 120.0) for c in made)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    lock, running = threading.Lock(), [True]

    def spin() -> None:
        while running[0]:
            with lock:
                executor.spin_once(timeout_sec=0.005)
    print(f"ready {found}", flush=True)
    start_at = float(sys.stdin.readline())
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    time.sleep(max(0.0, start_at - time.time()))
    sent_at, futures = [], []
    with lock:  # rclpy's ActionClient drops an answer taken before the future is kept
        for k, c in enumerate(made):
            sent_at.append(time.monotonic())
            futures.append(door.send(c, k))
    figures = _gather(door, futures, sent_at, lock)
    running[0] = False
    spinner.join(5)
    print(json.dumps(figures), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def _gather(door: _Door, futures: list, sent_at: list[float], lock: threading.Lock) -> dict:
    answered: dict[int, float] = {}
    results: dict[int, object] = {}
    result_at: dict[int, float] = {}
    rejected = 0
    end = time.monotonic() + LIMIT_S
    while time.monotonic() < end:
        now = time.monotonic()
        for k, f in enumerate(futures):
            if k not in answered and f.done():
                answered[k] = now - sent_at[k]
                if not door.action:
                    result_at[k] = answered[k]
                    results[k] = f
                elif f.result().accepted:
                    with lock:
                        results[k] = f.result().get_result_async()
                else:
                    rejected += 1
            elif door.action and k in results and k not in result_at and results[k].done():  # type: ignore[attr-defined]
                result_at[k] = now - sent_at[k]
        if len(answered) == len(futures) and len(result_at) == len(results):
            break
        time.sleep(0.005)
    ends = Counter(door.end(results[k].result()) for k in result_at)  # type: ignore[attr-defined]
    return {"sent": len(futures), "answered": sorted(answered.values()), "rejected": rejected,
            "results": sorted(result_at.values()), "ends": dict(ends)}


# ---------------------------------------------------------------------------- the parent
def _ms(values: list[float]) -> str:
    if not values:
        return "none"
    return (f"median {1000 * statistics.median(values):.0f} ms, longest {1000 * max(values):.0f} ms, "
            f"{sum(v <= TIMEOUT_S for v in values)} within {TIMEOUT_S:g} s")


def _gaps(sim, t0: float, t1: float) -> str:
    """The longest loop gap in [t0, t1] and how many gaps were over 50 ms (the simulator's log)."""
    times = [e.time for e in list(sim.log) if e.name.endswith("sync_read") and t0 <= e.time <= t1
             and e.address <= abuse.PRESENT_POSITION < e.address + (e.length or 0)]
    gaps = [b - a for a, b in zip(times, times[1:])]
    if not gaps:
        return "no loop"
    return f"{1000 * max(gaps):.0f} ms ({sum(g > 0.05 for g in gaps)} over 50 ms)"


def _child(nice: int) -> None:
    abuse._die_with_parent()
    if nice:
        os.nice(nice)


def crowd(node: abuse.Node, sim, door: str, depth: int, count: int = CLIENTS, nice: int = 0) -> None:
    """One crowd: the clients are made and find the node (discovery, measured apart), then all
    send at one instant (the requests, measured from that instant until every answer is in)."""
    sim_tid = crowd_probe.sim_thread_id()
    t_spawn = time.monotonic()
    procs = [subprocess.Popen([sys.executable, __file__, "--publish", f"{door}/{depth}", str(count), "0"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                              preexec_fn=functools.partial(_child, nice)) for _ in range(PROCESSES)]
    probe = crowd_probe.Probe(node.proc.pid, sim_tid, [p.pid for p in procs])
    found = [int(p.stdout.readline().split()[-1] or 0) for p in procs]  # type: ignore[union-attr]
    discovery = probe.stop()
    t_ready = time.monotonic()
    before = node.resources()
    start_at = time.time() + 1.0
    for p in procs:
        p.stdin.write(f"{start_at}\n")  # type: ignore[union-attr]
        p.stdin.flush()  # type: ignore[union-attr]
    time.sleep(max(0.0, start_at - time.time()))
    t0 = time.monotonic()
    probe = crowd_probe.Probe(node.proc.pid, sim_tid, [p.pid for p in procs])
    outs = [json.loads(p.stdout.readline() or "{}") for p in procs]  # type: ignore[union-attr]
    requests = probe.stop()
    t1 = time.monotonic()
    for p in procs:  # 250 action clients take a while to shut down
        try:
            p.wait(120)
        except subprocess.TimeoutExpired:
            p.kill()
    time.sleep(AFTER_S)
    sent = sum(o.get("sent", 0) for o in outs)
    answered = [v for o in outs for v in o.get("answered", [])]
    results = [v for o in outs for v in o.get("results", [])]
    ends: Counter = Counter()
    for o in outs:
        ends.update(o.get("ends", {}))
    rejected = sum(o.get("rejected", 0) for o in outs)
    action = door in ("move_joints", "follow_joint_trajectory")
    line = (f"{door:24s} depth {depth:<4d} nice {nice}; servers found {sum(found)}/{sent}; answers "
            f"{len(answered)}/{sent} ({_ms(answered)})")
    if action:
        line += f"; accepted {len(answered) - rejected}, rejected {rejected}; results {len(results)} ({_ms(results)})"
    print(f"{line}; ends {dict(ends.most_common(4))}", flush=True)
    print(f"    discovery: loop gap {_gaps(sim, t_spawn, t_ready)}; {crowd_probe.line(discovery)}", flush=True)
    print(f"    requests:  loop gap {_gaps(sim, t0, t1)}; {crowd_probe.line(requests)}", flush=True)
    print(f"    rss/threads/fds before {before}, peak {requests['rss_peak']:.0f} MiB, {AFTER_S:g} s after "
          f"{node.resources()}; {_trimmed()}", flush=True)


def _trimmed() -> str:
    """Asks the node to call malloc_trim(0) (bench/thread_names): RSS before and after it."""
    Path(TRIM).unlink(missing_ok=True)
    Path(TRIM + ".go").touch()
    end = time.monotonic() + 5.0
    while time.monotonic() < end and not Path(TRIM).exists():
        time.sleep(0.05)
    time.sleep(0.05)
    try:
        before, after, blocks, took, arenas = Path(TRIM).read_text().split()
    except (OSError, ValueError):
        return "malloc_trim: no answer"
    return (f"malloc_trim(0): RSS {before} -> {after} MiB in {took} ms (Python blocks in use {int(blocks):,}; "
            f"MiB in Python's arenas / in its blocks {arenas})")


def torque_on(ids: list[int]) -> None:
    """Torque on (one call), so that the moves and trajectories move the servos."""
    import abuse_services

    from dynamixel_handler_msgs.srv import SetTorque
    client = abuse_services.Client()
    try:
        with client.lock:
            cli = client.node.create_client(SetTorque, "/dynamixel/set_torque", qos_profile=client.qos)
        cli.wait_for_service(timeout_sec=10)
        done = cli.call_async(SetTorque.Request(ids=ids, enable=True))
        end = time.monotonic() + 10
        while not done.done() and time.monotonic() < end:
            time.sleep(0.01)
    finally:
        client.close()


def run(VirtualBus, seconds: float, doors: tuple[str, ...] = DOORS, depths: tuple[int, ...] = DEPTHS,
        count: int = CLIENTS, nices: tuple[int, ...] = (0,), params: tuple[str, ...] = (), stalls: str = "",
        hardware: bool = False, loop_fifo: bool = False) -> None:
    sim = VirtualBus(servos={1: abuse.X, 2: abuse.X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=2", "init/expected_servo_num:=2", *JOINTS, *params,
                      env={"PYTHONPATH": os.pathsep.join([crowd_probe.THREAD_NAMES, os.environ.get("PYTHONPATH", "")]),
                           "DXL_BENCH_TRIM": TRIM, **({"DXL_BENCH_STALLS": stalls} if stalls else {})})
    node.wait_for("handled")
    if hardware:  # the simulator answers on time as servos would, whatever the crowd takes
        from common import hardware_priority
        print(hardware_priority(), flush=True)
    if loop_fifo:  # an experiment: the node's loop thread never waits for a core (its lock it may)
        print(crowd_probe.loop_fifo(node.proc.pid), flush=True)
    time.sleep(2.0)
    torque_on([1, 2])
    t0 = time.monotonic()
    time.sleep(seconds)
    rate, gap = abuse.loop_figures(sim, t0, time.monotonic())
    print(f"{'idle':24s} loop {rate:.1f} Hz, gap {gap:.0f} ms; rss/threads/fds {node.resources()}", flush=True)
    probe = crowd_probe.Probe(node.proc.pid, crowd_probe.sim_thread_id(), [])
    time.sleep(seconds)
    print(f"    idle: loop gap {_gaps(sim, time.monotonic() - seconds, time.monotonic())}; "
          f"{crowd_probe.line(probe.stop())}; {_trimmed()}", flush=True)
    try:
        for door in doors:
            for depth in depths:
                for nice in nices:
                    crowd(node, sim, door, depth, count, nice)
                time.sleep(3.0)  # the last goals end before the next crowd
    finally:
        code, exit_s = node.stop()
        print(f"{'exit':24s} rc={code} {exit_s:.2f} s", flush=True)
        sim.stop()


def main() -> int:
    if "--publish" in sys.argv:
        return abuse.door_main(__doc__, run, lambda spec, count, _s: clients(spec, int(count)), 5.0)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0, help="idle time measured first [s]")
    ap.add_argument("--doors", default=",".join(DOORS))
    ap.add_argument("--depths", default=",".join(map(str, DEPTHS)))
    ap.add_argument("--clients", type=int, default=CLIENTS, help="clients per process (4 processes)")
    ap.add_argument("--nice", default="0", help="nice values of the client processes, each a crowd (e.g. 0,19)")
    ap.add_argument("-p", dest="params", action="append", default=[], help="a node parameter (name:=value)")
    ap.add_argument("--stalls", default="", help="a file: the node writes where its threads were whenever a "
                    "thread of its own woke over 50 ms late (bench/thread_names/sitecustomize.py)")
    ap.add_argument("--hardware-priority", action="store_true",
                    help="the simulator's thread at SCHED_FIFO (root): it answers on time as servos do")
    ap.add_argument("--loop-fifo", action="store_true",
                    help="an experiment: the node's loop thread at SCHED_FIFO 5 (root), set from outside")
    args = ap.parse_args()
    from dynamixel_handler.sim import VirtualBus
    run(VirtualBus, args.seconds, tuple(args.doors.split(",")), tuple(int(d) for d in args.depths.split(",")),
        args.clients, tuple(int(n) for n in args.nice.split(",")), tuple(args.params), args.stalls,
        args.hardware_priority, args.loop_fifo)
    return 0


if __name__ == "__main__":
    sys.exit(main())
