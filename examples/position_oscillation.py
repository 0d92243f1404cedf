#!/usr/bin/env python3
"""Example controller: swing X-series servos ±30° around where they are, with a current limit.

It only talks to dynamixel_handler through topics, as any upper node would:
  - subscribes ``dynamixel/states`` (DxlStates) for the present position and torque state;
  - publishes ``dynamixel/commands/x`` (DxlCommandsX): ``status.torque`` turns torque on while a
    servo reports it off; ``current_base_position_control`` carries the goal position and the goal
    current, which in current-based position mode is the current (torque) limit of the move.
The handler switches the servos to that mode by itself when the first control command arrives.

Run it against the virtual bus with one command: ``examples/run_example.sh`` (see there), or on a
robot with the handler running: ``python examples/position_oscillation.py --ids 1,2``.
Prints present vs goal once a second and, at the end (Ctrl-C or ``--duration``), how far each
servo actually swept.
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from dynamixel_handler_msgs.msg import DxlCommandsX, DxlStates

COMMAND_RATE_HZ = 50.0


class PositionOscillation(Node):
    """Sends a sine of goal positions around each servo's start position."""

    def __init__(self, ids: list[int], amplitude_deg: float, frequency_hz: float, current_limit_ma: float) -> None:
        super().__init__("position_oscillation")
        self.wanted = ids                     # empty: every ID in the first states message
        self.amplitude = amplitude_deg
        self.frequency = frequency_hz
        self.current_limit = current_limit_ma
        self.ids: list[int] = []
        self.start: dict[int, float] = {}     # position at the start [deg]
        self.present: dict[int, float] = {}
        self.torque: dict[int, bool] = {}
        self.goal: dict[int, float] = {}
        self.swing: dict[int, list[float]] = {}  # [min, max] of present - start
        self.t0: float | None = None
        self.pub = self.create_publisher(DxlCommandsX, "dynamixel/commands/x", 10)
        self.create_subscription(DxlStates, "dynamixel/states", self.on_states, 10)
        self.create_timer(1.0 / COMMAND_RATE_HZ, self.step)
        self.create_timer(1.0, self.print_status)

    @property
    def running(self) -> bool:
        return self.t0 is not None

    def on_states(self, msg: DxlStates) -> None:
        present = dict(zip(msg.present.id_list, msg.present.position_deg))
        self.present.update({i: p for i, p in present.items() if math.isfinite(p)})
        self.torque.update(zip(msg.status.id_list, msg.status.torque))
        if not self.ids:
            ids = self.wanted or sorted(self.present)
            missing = [i for i in ids if i not in self.present]
            if ids and not missing:
                self.ids = ids
                self.start = {i: self.present[i] for i in ids}
                self.get_logger().info(f"controlling IDs {ids}, start positions "
                                       + ", ".join(f"{i}: {self.start[i]:.1f} deg" for i in ids))
        if self.running:
            for i in self.ids:
                if i in self.present:
                    d = self.present[i] - self.start[i]
                    lo_hi = self.swing.setdefault(i, [d, d])
                    lo_hi[0], lo_hi[1] = min(lo_hi[0], d), max(lo_hi[1], d)

    def step(self) -> None:
        if not self.ids or self.pub.get_subscription_count() == 0:
            return  # wait for the handler to be up and to hear us
        now = time.monotonic()
        if self.t0 is None:
            self.t0 = now
        phase = 2.0 * math.pi * self.frequency * (now - self.t0)
        self.goal = {i: self.start[i] + self.amplitude * math.sin(phase) for i in self.ids}
        cmd = DxlCommandsX()
        off = [i for i in self.ids if not self.torque.get(i, False)]
        if off:
            cmd.status.id_list = off
            cmd.status.torque = [True] * len(off)
        ctrl = cmd.current_base_position_control
        ctrl.id_list = self.ids
        ctrl.position_deg = [self.goal[i] for i in self.ids]
        ctrl.current_ma = [self.current_limit] * len(self.ids)
        self.pub.publish(cmd)

    def print_status(self) -> None:
        if not self.running:
            print("waiting for dynamixel/states and the handler ...", flush=True)
            return
        t = time.monotonic() - self.t0
        parts = [f"ID {i}: goal {self.goal.get(i, math.nan):7.1f} present {self.present.get(i, math.nan):7.1f}"
                 for i in self.ids]
        print(f"t={t:5.1f}s  " + " | ".join(parts) + "  [deg]", flush=True)

    def summary(self) -> list[str]:
        out = []
        for i in self.ids:
            lo, hi = self.swing.get(i, [math.nan, math.nan])
            out.append(f"ID {i}: present position swept {hi - lo:.1f} deg "
                       f"({lo:+.1f} .. {hi:+.1f} around {self.start[i]:.1f}; goal ±{self.amplitude:g})")
        return out


def _ids(text: str) -> list[int]:
    return [int(t) for t in text.replace(" ", "").split(",") if t]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Oscillate X-series servos through dynamixel_handler's topics.")
    ap.add_argument("--ids", type=_ids, default=[], help="IDs to drive, e.g. 1,2 (default: all in the states)")
    ap.add_argument("--amplitude", type=float, default=30.0, help="swing around the start position [deg]")
    ap.add_argument("--frequency", type=float, default=0.5, help="oscillation frequency [Hz]")
    ap.add_argument("--current-limit", type=float, default=300.0, help="goal current = current limit [mA]")
    ap.add_argument("--duration", type=float, default=0.0, help="stop after S seconds of motion (0: until Ctrl-C)")
    ap.add_argument("--wait", type=float, default=30.0, help="give up if no states arrive within S seconds")
    args, ros_args = ap.parse_known_args(argv)
    rclpy.init(args=ros_args)
    node = PositionOscillation(args.ids, args.amplitude, args.frequency, args.current_limit)
    began = time.monotonic()
    code = 0
    try:
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.05)
            if not node.running and time.monotonic() - began > args.wait:
                print(f"no dynamixel/states with IDs {args.ids or 'any'} within {args.wait:g} s: "
                      f"is dynamixel_handler running (same ROS_DOMAIN_ID)?", file=sys.stderr)
                code = 1
                break
            if node.running and args.duration and time.monotonic() - node.t0 >= args.duration:
                break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    for line in node.summary():
        print(line, flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
