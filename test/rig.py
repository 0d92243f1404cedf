"""A test rig: a virtual bus, the real node process on it, and an rclpy node in the test process
that publishes commands and collects what the handler publishes."""
from __future__ import annotations

from typing import Callable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DxlStates, DynamixelDebug

from ros_helpers import NodeProcess, TopicClient, node_command

X, X540, P, PRO = 1020, 1120, 2020, 54024  # XM430-W350, XM540-W270, PH54-200-S500-R, H54-200-S500-R


class Rig(TopicClient):
    def __init__(self, servos: dict[int, int], *params: str, sim_kwargs: dict | None = None,
                 expect: int | None = None, before_start: Callable[[VirtualBus], None] | None = None,
                 env: dict[str, str] | None = None) -> None:
        """``expect``: number of IDs the node should handle (default: every simulated servo);
        ``env``: extra environment of the node process."""
        # the servos as unboxed (57600 bps, the node's default; answering only at that rate), but
        # untimed replies: wire timing is opted into per test (``sim_kwargs``)
        self.sim = VirtualBus(servos=servos, **{"wire_timing": False, **(sim_kwargs or {})})
        path = self.sim.start()
        if before_start is not None:
            before_start(self.sim)
        ids = sorted(servos)
        n = len(servos) if expect is None else expect
        # a loaded machine can delay the simulator's reply past a 1 ms adapter's timeout: the scan
        # retries until every servo was seen
        args = [f"device_name:={path}", "latency_timer:=1", "init/used_servo_series.P:=true",
                "init/used_servo_series.Pro:=true", f"init/servo_auto_search.min_id:={ids[0]}",
                f"init/servo_auto_search.max_id:={ids[-1]}", "init/servo_auto_search.retry_times:=5",
                f"init/expected_servo_num:={n}", "verbose_ratio:=0", *params]
        self.node_proc = NodeProcess(node_command(*args), env=env)
        rclpy.init()
        self.node = Node("test_rig")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.states: list[DxlStates] = []
        self.debug: list[DynamixelDebug] = []
        self.node.create_subscription(DxlStates, "/dynamixel/states", self.states.append, 50)
        self.node.create_subscription(DynamixelDebug, "/dynamixel/debug", self.debug.append, 50)
        self._start_spinning()
        try:
            self.node_proc.wait_for("handled", timeout=30)
            self.wait(lambda: self.debug and len(self.debug[-1].status.id_list) == n
                      and len(self.debug[-1].position_deg.present) == n, timeout=30,
                      what="the first /dynamixel/debug with every servo")
        except BaseException:
            self.close()
            raise

    @property
    def output(self) -> str:
        return self.node_proc.output

    def debug_of(self, dxl_id: int) -> dict:
        """Latest debug values of one ID: present/goal of position, velocity, current; torque; mode."""
        msg = self.debug[-1]
        k = list(msg.status.id_list).index(dxl_id)
        return {"position": msg.position_deg.present[k], "goal_position": msg.position_deg.goal[k],
                "velocity": msg.velocity_deg_s.present[k], "goal_velocity": msg.velocity_deg_s.goal[k],
                "current": msg.current_ma.present[k], "goal_current": msg.current_ma.goal[k],
                "torque": msg.status.torque[k], "mode": msg.status.mode[k], "error": msg.status.error[k],
                "ping": msg.status.ping[k]}

    # ------------------------------------------------------------------ helpers for command tests
    def mark(self) -> int:
        """A position in the node's log; ``log_since``/``wait_log`` look only at what came after."""
        return len(self.node_proc.lines)

    def log_since(self, mark: int) -> str:
        return "\n".join(self.node_proc.lines[mark:])

    def wait_log(self, *substrings: str, since: int = 0, timeout: float = 10.0) -> str:
        """Wait until one line after ``since`` holds every one of ``substrings``; that line."""
        found: list[str] = []

        def seen() -> bool:
            found[:] = [line for line in self.node_proc.lines[since:] if all(s in line for s in substrings)]
            return bool(found)
        self.wait(seen, timeout=timeout, what=f"a log line with {substrings!r}")
        return found[0]

    def group(self, name: str):
        """The latest published DxlStates part ``name`` (status, present, goal, gain, limit, error,
        extra) that was read in its loop (non-empty id_list); None before the first."""
        for msg in reversed(self.states):
            part = getattr(msg, name)
            if len(part.id_list):
                return part
        return None

    def state_of(self, name: str, field: str, dxl_id: int):
        """One ID's value of a (possibly nested, dotted) field of the latest DxlStates part ``name``."""
        part = self.group(name)
        if part is None or dxl_id not in list(part.id_list):
            return None
        k = list(part.id_list).index(dxl_id)
        value = part
        for attr in field.split("."):
            value = getattr(value, attr)
        return value[k] if len(value) > k else None

    def fresh_states(self, count: int = 2, timeout: float = 10.0) -> None:
        """Wait for ``count`` more DxlStates of each group published (so they hold current reads)."""
        n = len(self.states)
        self.wait(lambda: len(self.states) >= n + count, timeout=timeout, what=f"{count} more /dynamixel/states")

    def turn_by_hand(self, dxl_id: int, pulses: float) -> None:
        """Turn the shaft of a servo as a hand would (no instruction on the bus): the virtual
        servo has no public hook for an external force, so the motor model is moved directly.
        Meant for a servo with torque off (with torque on it would just drive back)."""
        with self.sim._lock:
            servo = self.sim.servo(dxl_id)
            servo.refresh(servo._clock())
            servo._motor.p += pulses
            servo.refresh(servo._clock())

    def close(self) -> int:
        code = self.node_proc.stop()
        self._stop_spinning()
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()
        self.sim.stop()
        return code
