"""Publishes the load test's command mix from its own process (so the virtual bus in the test
process does not share a CPU core's GIL with 1000 publishes a second) and records what it sent.

usage: python load_publisher.py SERVOS PUBLISHERS RATE_HZ SECONDS OUT.json
"""
from __future__ import annotations

import json
import os
import sys
import time

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

import rclpy  # noqa: E402
from rclpy.node import Node  # noqa: E402

from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelGoal  # noqa: E402


def pulses(deg: float) -> int:
    return 2048 + round(deg * 4096 / 360)


def main() -> None:
    n_servos, n_pubs, rate, seconds, out = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
    rclpy.init()
    node = Node("load_publisher")
    pos_pub = [node.create_publisher(DynamixelControlXPosition, "/dynamixel/command/x/position_control", 100)
               for _ in range(n_pubs // 2 + n_pubs % 2)]
    goal_pub = [node.create_publisher(DynamixelGoal, "/dynamixel/command/goal", 100) for _ in range(n_pubs // 2)]
    deadline = time.monotonic() + 10
    while any(p.get_subscription_count() == 0 for p in pos_pub + goal_pub) and time.monotonic() < deadline:
        time.sleep(0.05)
    commanded = {i: [pulses(0.0)] for i in range(1, n_servos + 1)}
    last_pos, last_vel, sent = {}, {}, 0
    t0 = next_t = time.monotonic()
    seq = 0
    while time.monotonic() - t0 < seconds:
        for j in range(n_pubs):
            ids = [(j + m) % n_servos + 1 for m in range(3)]
            if j % 2 == 0:
                degs = [((seq * 7 + j * 13 + m * 31) % 3000) / 20.0 - 75.0 for m in range(3)]
                pos_pub[j // 2].publish(DynamixelControlXPosition(id_list=ids, position_deg=degs))
                for i, d in zip(ids, degs):
                    commanded[i].append(pulses(d))
                    last_pos[i] = pulses(d)
            else:
                vel = [float((seq + j + m) % 200 + 1) for m in range(3)]
                goal_pub[j // 2].publish(DynamixelGoal(id_list=ids, profile_vel_deg_s=vel))
                for i, v in zip(ids, vel):
                    last_vel[i] = round(v / (0.229 * 6))
            sent += 1
        seq += 1
        next_t += 1.0 / rate
        time.sleep(max(0.0, next_t - time.monotonic()))
    time.sleep(0.5)  # let the middleware deliver the last messages
    with open(out, "w") as f:
        json.dump({"commanded": {i: sorted(set(v)) for i, v in commanded.items()}, "last_pos": last_pos,
                   "last_vel": last_vel, "sent": sent, "elapsed": time.monotonic() - t0}, f)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
