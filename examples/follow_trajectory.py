#!/usr/bin/env python3
"""Send one FollowJointTrajectory goal to dynamixel_handler, as MoveIt would, and plot how the
servos followed it: commanded (the interpolated path) vs present position, saved as a PNG.

No MoveIt and no ros2_control: the handler serves ``/dynamixel_handler/follow_joint_trajectory``
itself. The trajectory starts where the joints are and visits three points (positions and
velocities, so the path between them is cubic), starting ``--delay`` seconds after it is sent
(``header.stamp``).

    python examples/follow_trajectory.py --virtual --png trajectory.png   # its own virtual bus and handler
    python examples/follow_trajectory.py --joints pan,tilt                # a handler already running

``--virtual`` starts ``dynamixel_handler_sim`` (two XM430 at IDs 1 and 2) and the handler with
``examples/robot/handler.yaml`` (joints pan and tilt), and stops both at the end. Exit code 0
when the goal succeeded and the plot was written.
"""
from __future__ import annotations

import argparse
import math
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt  # noqa: E402
import rclpy  # noqa: E402
from builtin_interfaces.msg import Duration  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

try:
    from control_msgs.action import FollowJointTrajectory
except ImportError:
    sys.exit("control_msgs is not installed: sudo apt install ros-jazzy-control-msgs (or scripts/setup.sh here)")

HERE = Path(__file__).resolve().parent
ACTION = "/dynamixel_handler/follow_joint_trajectory"
CODES = {getattr(FollowJointTrajectory.Result, k): k for k in ("SUCCESSFUL", "INVALID_GOAL", "INVALID_JOINTS",
                                                                "OLD_HEADER_TIMESTAMP", "PATH_TOLERANCE_VIOLATED",
                                                                "GOAL_TOLERANCE_VIOLATED")}


def start_virtual(log_dir: Path) -> tuple[list[subprocess.Popen], str]:
    """The virtual bus (two XM430 at 1 Mbps) and the handler on it; (processes, device)."""
    sim = subprocess.Popen(["dynamixel_handler_sim", "--quiet", "--ids", "1,2", "--models", "XM430-W350",
                            "--baudrate", "1000000"], stdout=subprocess.PIPE, text=True, start_new_session=True)
    device = sim.stdout.readline().strip()
    if not device:
        sim.kill()
        sys.exit("the virtual bus did not start")
    share = HERE.parent / "config"
    log = open(log_dir / "handler.log", "w")
    node = subprocess.Popen(["dynamixel_handler", "--ros-args", "--params-file", str(share / "config_dynamixel_handler.yaml"),
                             "--params-file", str(HERE / "robot" / "handler.yaml"), "-p", f"device_name:={device}",
                             "-p", "baudrate:=1000000", "-p", "latency_timer:=1"],
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    return [node, sim], device


def stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:  # the handler first (SIGINT: it stops the servos), then the bus
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()


class Recorder(Node):
    def __init__(self, joints: list[str]) -> None:
        super().__init__("follow_trajectory_example")
        self.joints = joints
        self.present: list[tuple[float, list[float]]] = []   # (time, positions in joint order)
        self.feedback: list[tuple[float, list[float], list[float]]] = []  # (time, desired, actual)
        self.create_subscription(JointState, "/joint_states", self._on_states, 50)
        self.client = ActionClient(self, FollowJointTrajectory, ACTION)

    def _on_states(self, msg: JointState) -> None:
        if all(j in msg.name for j in self.joints):
            t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            self.present.append((t, [msg.position[list(msg.name).index(j)] for j in self.joints]))

    def on_feedback(self, m) -> None:
        fb = m.feedback
        t = fb.header.stamp.sec + fb.header.stamp.nanosec * 1e-9
        self.feedback.append((t, list(fb.desired.positions), list(fb.actual.positions)))


def duration(t: float) -> Duration:
    return Duration(sec=int(t), nanosec=int(round((t % 1.0) * 1e9)))


def wait_for(pred, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.02)
    return False


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--virtual", action="store_true", help="start a virtual bus and the handler first")
    ap.add_argument("--joints", default="pan,tilt", help="joint names (default pan,tilt)")
    ap.add_argument("--amplitude", type=float, default=0.8, help="largest excursion from the start [rad]")
    ap.add_argument("--delay", type=float, default=0.5, help="start this long after sending [s]")
    ap.add_argument("--png", default="follow_trajectory.png", help="where to save the plot")
    args = ap.parse_args()
    joints = [j.strip() for j in args.joints.split(",") if j.strip()]
    procs: list[subprocess.Popen] = []
    if args.virtual:
        log_dir = Path(tempfile.mkdtemp(prefix="follow_trajectory_"))  # a directory of this run's own
        procs, device = start_virtual(log_dir)
        print(f"virtual bus on {device}; handler log: {log_dir / 'handler.log'}")
    rclpy.init()
    node = Recorder(joints)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinning = True
    # rclpy's ActionClient drops an answer the spinning thread takes before the request's future is
    # registered (ros2/rclpy#1123): requests are sent while the spinning thread is held off
    spin_lock = threading.Lock()

    def spin() -> None:
        while spinning:
            with spin_lock:
                executor.spin_once(timeout_sec=0.02)
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    try:
        if not wait_for(lambda: node.client.server_is_ready() or any(p.poll() is not None for p in procs), 60.0) \
                or not node.client.server_is_ready():
            died = [p.args[0] for p in procs if p.poll() is not None]
            print(f"no {ACTION} action: is dynamixel_handler running with joint_state.use and control_msgs?"
                  + (f" ({', '.join(died)} exited)" if died else ""), file=sys.stderr)
            return 1
        if not wait_for(lambda: node.present, 10.0):
            print(f"no /joint_states with {joints}: check joint_state.names", file=sys.stderr)
            return 1
        start = node.present[-1][1]
        a = args.amplitude
        shape = [(1.0, [a, -0.5 * a], [0.4, -0.4]), (2.0, [-0.5 * a, 0.5 * a], [-0.3, 0.6]), (3.0, [0.0, 0.0], [0.0, 0.0])]
        traj = JointTrajectory(joint_names=joints)
        for t, offsets, vel in shape:
            traj.points.append(JointTrajectoryPoint(
                positions=[s + o for s, o in zip(start, offsets[:len(joints)])],
                velocities=vel[:len(joints)], time_from_start=duration(t)))
        t0 = node.get_clock().now().nanoseconds * 1e-9 + args.delay
        traj.header.stamp.sec, traj.header.stamp.nanosec = int(t0), int((t0 % 1.0) * 1e9)
        with spin_lock:
            goal_future = node.client.send_goal_async(FollowJointTrajectory.Goal(trajectory=traj),
                                                      feedback_callback=node.on_feedback)
        if not wait_for(goal_future.done, 10.0) or not goal_future.result().accepted:
            print("the goal was not accepted", file=sys.stderr)
            return 1
        with spin_lock:
            result_future = goal_future.result().get_result_async()
        if not wait_for(result_future.done, shape[-1][0] + args.delay + 10.0):
            print("no result in time", file=sys.stderr)
            return 1
        result = result_future.result().result
        time.sleep(0.3)  # a few more joint states after the end
        errors = [abs(d - p) for _, desired, actual in node.feedback for d, p in zip(desired, actual)]
        worst = max(errors) if errors else math.nan
        median = statistics.median(errors) if errors else math.nan
        print(f"result: {CODES.get(result.error_code, result.error_code)} {result.error_string}".rstrip())
        print(f"feedback messages: {len(node.feedback)}, max |commanded - present|: {worst:.4f} rad "
              f"({math.degrees(worst):.2f} deg), median {median:.4f} rad")
        plot(node, joints, traj, t0, Path(args.png))
        print(f"plot saved to {args.png}")
        return 0 if result.error_code == FollowJointTrajectory.Result.SUCCESSFUL else 1
    finally:
        spinning = False
        spinner.join(2.0)
        node.destroy_node()
        rclpy.try_shutdown()
        stop(procs)


def plot(node: Recorder, joints: list[str], traj: JointTrajectory, t0: float, path: Path) -> None:
    fig, axes = plt.subplots(len(joints), 1, sharex=True, figsize=(8, 2.6 * len(joints)), squeeze=False)
    for k, (name, ax) in enumerate(zip(joints, axes[:, 0])):
        ax.plot([t - t0 for t, _ in node.present], [p[k] for _, p in node.present], label="present (joint_states)")
        ax.plot([t - t0 for t, _, _ in node.feedback], [d[k] for _, d, _ in node.feedback], "--",
                label="commanded (feedback: desired)")
        ax.plot([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in traj.points],
                [p.positions[k] for p in traj.points], "o", label="trajectory points")
        ax.set_ylabel(f"{name} [rad]")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("time from the trajectory's start [s]")
    fig.suptitle("FollowJointTrajectory on dynamixel_handler")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
