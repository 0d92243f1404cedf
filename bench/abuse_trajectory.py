#!/usr/bin/env python3
"""Hostile cases of the joint doors against the real node on a virtual bus: follow_joint_trajectory
and joint_commands.

    source env.sh && python bench/abuse_trajectory.py [--seconds N]
    (or from bench/abuse.py: ``abuse_trajectory.run(VirtualBus, seconds)``)

Cases, each printing one line:

- ``fjt_100k_points``: a goal of 100,000 points (over the documented maximum): its answer and
  latency, longest loop gap, RSS before / after / once the goal ended;
- ``fjt_max_points x3``: three goals of the largest accepted size (``trajectory.MAX_POINTS``) over
  ``seconds``, one after the other: the same figures, RSS after each;
- ``fjt_device_gone``: the adapter vanishes 2 s into a 6 s trajectory: time to the goal's end and
  its error string, log lines a second per cause while it is gone, a goal sent while it is gone;
- ``joint_commands_1khz`` and ``commands_x_1khz``: 1,000 valid messages a second for 3 x ``seconds``
  on each (JointState for two joints; DxlCommandsX position_control for the same servos): loop
  rate, longest gap, node CPU;
- ``joint_commands_100MB``: one JointState of 100,000 names (~100 MB): loop gap, RSS before and after.

A third servo, not a joint, runs in velocity mode with its bus watchdog armed: a stalled loop trips it.

Loop figures come from the simulator's log of the node's reads (``abuse.loop_figures``). Not part
of the test suite; the figures go to docs/reliability.md by hand.
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import abuse  # noqa: E402  (sets the ROS environment of the bench: localhost, a domain of its own)

#: the joints; present positions read every loop (a trajectory is judged on each), so the loop
#: figures below count every loop
JOINTS = ("joint_state.use:=true", "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]",
          "pub_ratio/present.position:=1")
ACTION = "/dynamixel_handler/follow_joint_trajectory"


# ---------------------------------------------------------------------------- publisher processes
def publish(kind: str, rate: float, seconds: float) -> None:
    """Runs in a process of its own: ``joint_commands`` / ``commands_x`` at ``rate`` Hz, or one
    ``huge`` JointState (100,000 names of ~1 kB)."""
    import rclpy
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from dynamixel_handler_msgs.msg import DxlCommandsX, DynamixelControlXPosition
    rclpy.init()
    node = Node(f"abuse_traj_{kind}")
    typ, topic = (DxlCommandsX, "/dynamixel/commands/x") if kind == "commands_x" else (JointState, "/joint_commands")
    pub = node.create_publisher(typ, topic, 100)
    end = time.monotonic() + 10
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        time.sleep(0.05)
    if kind == "huge":
        n = 100_000
        pub.publish(JointState(name=[f"{k:06d}" + "j" * 994 for k in range(n)], position=[0.1] * n))
        time.sleep(3.0)
        print(1, flush=True)
        return
    t0 = next_t = time.monotonic()
    k = 0
    while time.monotonic() - t0 < seconds:
        a = 0.3 * ((k % 200) / 100.0 - 1.0)
        if kind == "commands_x":
            pub.publish(DxlCommandsX(position_control=DynamixelControlXPosition(
                id_list=[1, 2], position_deg=[57.3 * a, -57.3 * a])))
        else:
            pub.publish(JointState(name=["pan", "tilt"], position=[a, -a]))
        k += 1
        next_t += 1.0 / rate
        time.sleep(max(0.0, next_t - time.monotonic()))
    time.sleep(0.3)
    print(k, flush=True)


def publisher(kind: str, rate: float, seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, __file__, "--publish", kind, str(rate), str(seconds)],
                            stdout=subprocess.PIPE, text=True, preexec_fn=abuse._die_with_parent)


# ---------------------------------------------------------------------------- an action client
class Client:
    """A FollowJointTrajectory client in this process (a context and executor of its own)."""

    def __init__(self) -> None:
        import rclpy
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        self.rclpy, self.FJT = rclpy, FollowJointTrajectory
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("abuse_traj_client", context=self.context)
        self.lock = threading.Lock()
        self.client = ActionClient(self.node, FollowJointTrajectory, ACTION)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = False
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self.client.wait_for_server(timeout_sec=20)

    def _spin(self) -> None:
        while not self._stop:
            with self.lock:
                self.executor.spin_once(timeout_sec=0.01)
            time.sleep(0.001)

    def goal(self, points: int, seconds: float, to: float = 0.5):
        from builtin_interfaces.msg import Duration
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
        pts = []
        for k in range(points):
            t = seconds * (k + 1) / points
            pts.append(JointTrajectoryPoint(positions=[to * (k + 1) / points, -to * (k + 1) / points],
                                            time_from_start=Duration(sec=int(t), nanosec=int((t % 1) * 1e9))))
        return self.FJT.Goal(trajectory=JointTrajectory(joint_names=["pan", "tilt"], points=pts))

    def run(self, goal, timeout: float = 60.0, while_running=None):
        """Send ``goal`` and wait for its result: (accepted, status, error code, error string,
        seconds to the result)."""
        t0 = time.monotonic()
        with self.lock:
            fut = self.client.send_goal_async(goal)
        _wait(fut.done, timeout)
        handle = fut.result()
        if handle is None or not handle.accepted:
            return False, None, None, "rejected", time.monotonic() - t0
        with self.lock:
            res = handle.get_result_async()
        if while_running is not None:
            while_running()
        _wait(res.done, timeout)
        if not res.done():
            return True, None, None, "no result", time.monotonic() - t0
        r = res.result()
        return True, r.status, r.result.error_code, r.result.error_string, time.monotonic() - t0

    def close(self) -> None:
        self._stop = True
        self._thread.join()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)


def _wait(pred, timeout: float) -> None:
    end = time.monotonic() + timeout
    while not pred() and time.monotonic() < end:
        time.sleep(0.01)


# ---------------------------------------------------------------------------- cases
def _causes(lines: list[str]) -> str:
    """Log lines by cause (the text after the logger name, digits masked), the busiest first."""
    import re
    c = Counter(re.sub(r"[0-9.]+", "#", line.split("]: ", 1)[-1])[:50] for line in lines)
    return "; ".join(f"{n}x {k}" for k, n in c.most_common(3)) or "-"


def _trips(lines: list[str]) -> int:
    return sum("bus watchdog tripped" in line or "bus watchdog had tripped" in line for line in lines)


def _goal_case(name: str, node, sim, client: Client, points: int, seconds: float) -> None:
    from common import cpu_seconds
    t_build = time.monotonic()
    goal = client.goal(points, seconds)
    build_s = time.monotonic() - t_build
    before = node.resources()[0]
    mark = len(node.lines)
    cpu0 = cpu_seconds(node.proc.pid)
    t0 = time.monotonic()
    accepted, status, code, text, took = client.run(goal, timeout=seconds + 60)
    t1 = time.monotonic()
    cpu = 100 * (cpu_seconds(node.proc.pid) - cpu0) / (t1 - t0)
    del goal
    after = node.resources()[0]
    time.sleep(2.0)  # the goal ended: what the node gives back
    ended = node.resources()[0]
    _, gap = abuse.loop_figures(sim, t0, t1)
    lines = [line for _, line in node.lines[mark:]]
    print(f"{name:22s} answers=1/1 latency={took:6.2f} s status={status} code={code} '{text[:60]}' "
          f"gap={gap:6.1f} ms cpu={cpu:.0f}% trips={_trips(lines)} rss before/after/ended {before}/{after}/{ended} MiB "
          f"log {len(lines) / (time.monotonic() - t0):.1f} lines/s ({_causes(lines)[:100]}) "
          f"(goal built in {build_s:.1f} s)", flush=True)


def _device_case(VirtualBus, client_factory) -> None:
    sim = VirtualBus(servos={1: abuse.X, 2: abuse.X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=2", "init/expected_servo_num:=2", *JOINTS)
    node.wait_for("loop running")
    client = client_factory()
    try:
        mark = len(node.lines)
        gone_at: list[float] = []

        def vanish_later() -> None:
            time.sleep(2.0)
            sim.vanish()
            gone_at.append(time.monotonic())
        threading.Thread(target=vanish_later, daemon=True).start()
        accepted, status, code, text, _ = client.run(client.goal(60, 6.0), timeout=30)
        abort_s = time.monotonic() - gone_at[0] if gone_at else float("nan")
        accepted2, status2, code2, text2, took2 = client.run(client.goal(10, 1.0), timeout=30)
        time.sleep(3.0)
        t1 = time.monotonic()
        lines = [line for t, line in node.lines[mark:] if gone_at and t >= gone_at[0]]
        rate = len(lines) / (t1 - gone_at[0]) if gone_at else float("nan")
        print(f"{'fjt_device_gone':22s} aborted {abort_s:5.2f} s after the loss: code={code} '{text[:60]}'; "
              f"goal while gone: code={code2} in {took2:.2f} s '{text2[:40]}'; "
              f"log {rate:.1f} lines/s ({_causes(lines)})", flush=True)
        sim.reappear()
    finally:
        client.close()
        node.stop()
        sim.stop()


def _load_case(name: str, node, sim, kind: str, seconds: float) -> None:
    from common import cpu_seconds
    cpu0, w0 = cpu_seconds(node.proc.pid), time.monotonic()
    mark = len(node.lines)
    proc = publisher(kind, 1000.0, seconds)
    time.sleep(1.5)
    t0 = time.monotonic()
    sent = int((proc.communicate(timeout=seconds + 60)[0] or "0").split()[-1])
    t1 = time.monotonic()
    rate, gap = abuse.loop_figures(sim, t0, t1 - 0.3)
    cpu = 100 * (cpu_seconds(node.proc.pid) - cpu0) / (time.monotonic() - w0)
    lines = [line for t, line in node.lines[mark:] if t0 <= t <= t1]
    print(f"{name:22s} sent={sent:6d} loop={rate:6.1f} Hz gap={gap:6.1f} ms cpu={cpu:4.0f}% trips={_trips(lines)} "
          f"log={len(lines) / (t1 - t0):.1f} lines/s rss={node.resources()[0]} MiB", flush=True)


def _huge_case(node, sim) -> None:
    mark = len(node.lines)
    before = node.resources()[0]
    proc = publisher("huge", 1.0, 1.0)
    t0 = time.monotonic()
    proc.communicate(timeout=120)
    t1 = time.monotonic()
    time.sleep(1.0)
    _, gap = abuse.loop_figures(sim, t0, t1)
    lines = [line for _, line in node.lines[mark:]]
    print(f"{'joint_commands_100MB':22s} gap={gap:6.1f} ms trips={_trips(lines)} rss before/after {before}/"
          f"{node.resources()[0]} MiB log: {_causes(lines)[:120]}", flush=True)


def run(VirtualBus, seconds: float) -> None:
    from dynamixel_handler.commands import trajectory
    max_points = getattr(trajectory, "MAX_POINTS", 1_000)  # the code before the maximum: the same size
    sim = VirtualBus(servos={1: abuse.X, 2: abuse.X, 3: abuse.X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=3", "init/expected_servo_num:=3", "verbose_ratio:=300",
                      *JOINTS)
    node.wait_for("loop running")
    time.sleep(2.0)
    abuse.velocity_mode([3])  # its bus watchdog is armed, so a stalled loop trips it
    client = Client()
    try:
        t0 = time.monotonic()
        time.sleep(seconds)
        rate, gap = abuse.loop_figures(sim, t0, time.monotonic())
        print(f"{'idle':22s} loop={rate:6.1f} Hz gap={gap:6.1f} ms rss={node.resources()[0]} MiB", flush=True)
        _goal_case("fjt_100k_points", node, sim, client, 100_000, 10.0)
        for k in range(3):
            _goal_case(f"fjt_max_points #{k + 1}", node, sim, client, max_points, seconds)
        _load_case("joint_commands_1khz", node, sim, "joint_commands", 3 * seconds)
        _load_case("commands_x_1khz", node, sim, "commands_x", 3 * seconds)
        _huge_case(node, sim)
    finally:
        client.close()
        node.stop()
        sim.stop()
    _device_case(VirtualBus, Client)


def main() -> int:
    return abuse.door_main(__doc__, run, publish, 10.0)


if __name__ == "__main__":
    sys.exit(main())
