"""Shared bench for the handler-core tests: a virtual bus of X, P and Pro servos, the real node
process on it, and an rclpy node in the test process that keeps every state message it receives.

Nothing of ours is replaced: the node is the installed console script, the bus is a pty served by
the virtual bus, and the messages travel through real DDS on this test run's own domain.
"""
from __future__ import annotations

import threading
import time
from typing import Iterable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import (DxlStates, DynamixelDebug, DynamixelError, DynamixelExtra, DynamixelGain,
                                        DynamixelGoal, DynamixelLimit, DynamixelPresent, DynamixelStatus)

from ros_helpers import NodeProcess, TopicClient, node_command

#: XM430-W350, XM540-W270, PH54-200-S500-R, H54-200-S500-R (old Pro firmware)
XM430, XM540, PH54, H54 = 1020, 1120, 2020, 54024
FOUR_SERVOS = {1: XM430, 2: XM540, 3: PH54, 4: H54}

#: Protocol 2.0 instruction codes (e-Manual, Protocol 2.0 "Instruction")
PING, READ, WRITE, SYNC_READ, SYNC_WRITE, FAST_SYNC_READ = 0x01, 0x02, 0x03, 0x82, 0x83, 0x8A

STATE_TOPICS = {
    "status": DynamixelStatus, "present": DynamixelPresent, "goal": DynamixelGoal, "gain": DynamixelGain,
    "limit": DynamixelLimit, "error": DynamixelError, "extra": DynamixelExtra,
}

#: parameters every bench uses: a fast adapter, every series on, quiet unless a test asks
BASE_PARAMS = ("latency_timer:=1", "loop_rate:=100", "verbose_ratio:=0", "init/used_servo_series.X:=true",
               "init/used_servo_series.P:=true", "init/used_servo_series.Pro:=true",
               "init/servo_auto_search.min_id:=0", "init/servo_auto_search.max_id:=6")


class Received:
    """Messages of one topic in arrival order, with their arrival time (monotonic)."""

    def __init__(self) -> None:
        self._items: list[tuple[float, object]] = []
        self._lock = threading.Lock()

    def add(self, msg: object) -> None:
        with self._lock:
            self._items.append((time.monotonic(), msg))

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)

    def since(self, t: float) -> list:
        with self._lock:
            return [m for when, m in self._items if when >= t]

    def stamped(self) -> list[tuple[float, object]]:
        """(arrival time, message) pairs."""
        with self._lock:
            return list(self._items)

    def all(self) -> list:
        with self._lock:
            return [m for _, m in self._items]

    def last(self):
        with self._lock:
            return self._items[-1][1] if self._items else None


class Bench(TopicClient):
    """A virtual bus, a listening rclpy node, then the handler node process on the bus."""

    def __init__(self, *params: str, servos: dict[int, int] | None = None, wait_ids: Iterable[int] | None = None,
                 start_node: bool = True, env: dict[str, str] | None = None) -> None:
        self.env = env
        self.sim = VirtualBus(servos=dict(FOUR_SERVOS if servos is None else servos), wire_timing=False)
        for param in params:  # the servos at the node's baud rate (they answer only at their own)
            if param.startswith("baudrate:="):
                self.sim.set_baudrate(int(param.split(":=", 1)[1]))
        self.device = self.sim.start()
        self.node_proc: NodeProcess | None = None
        # listen first, so the node's first loops reach us once discovery is done
        self.context = rclpy.Context()  # its own context: benches may overlap (module fixtures)
        rclpy.init(context=self.context)
        self.node = Node(f"core_test_listener_{id(self):x}", context=self.context)
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.topics: dict[str, Received] = {}
        for name, typ in (("states", DxlStates), ("debug", DynamixelDebug),
                          *((f"state/{g}", t) for g, t in STATE_TOPICS.items())):
            self.topics[name] = Received()
            self.node.create_subscription(typ, f"/dynamixel/{name}", self.topics[name].add, qos)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._start_spinning()
        if start_node:
            try:
                self.start_node(*params, wait_ids=wait_ids)
            except BaseException:
                self.close()
                raise

    # ------------------------------------------------------------------ node process
    def start_node(self, *params: str, wait_ids: Iterable[int] | None = None) -> None:
        """Start the handler on the bus and wait until it publishes states of ``wait_ids``
        (default: every simulated servo)."""
        args = (f"device_name:={self.device}", *BASE_PARAMS, *params)
        self.node_proc = NodeProcess(node_command(*args), env=self.env)
        ids = sorted(self.sim.servos if wait_ids is None else wait_ids)
        self.wait(lambda: (m := self.topics["debug"].last()) is not None and list(m.status.id_list) == ids,
                  timeout=30, what=f"/dynamixel/debug with IDs {ids}")

    def stop_node(self, sig=None) -> int:
        """Stop the node (SIGINT unless told) and return its exit code."""
        assert self.node_proc is not None
        return self.node_proc.stop() if sig is None else self.node_proc.stop(sig)

    @property
    def output(self) -> str:
        return self.node_proc.output if self.node_proc is not None else ""

    # ------------------------------------------------------------------ topics
    def wait_new(self, topics: Iterable[str], count: int, timeout: float = 10.0) -> float:
        """Wait until each topic delivered ``count`` messages from now on; return the start time."""
        start = time.monotonic()
        for topic in topics:
            self.wait(lambda: len(self.topics[topic].since(start)) >= count, timeout=timeout,
                      what=f"{count} new messages on /dynamixel/{topic}")
        return start

    # ------------------------------------------------------------------ the wire
    def transactions(self) -> list:
        """The instructions the bus received, a retry (the same packet again right after, when a
        reply was late on a loaded machine) counted once."""
        out, last = [], None
        for e in self.sim.log:
            key = (e.instruction, e.ids, e.address, e.length, e.params)
            if key != last:
                out.append(e)
            last = key
        return out

    def sync_reads(self, address: int, dxl_id: int) -> list:
        """Sync reads (plain or fast) addressed to ``dxl_id`` whose span covers ``address``, in order."""
        return [e for e in self.transactions() if e.instruction in (SYNC_READ, FAST_SYNC_READ)
                and e.address <= address < e.address + e.length and dxl_id in e.ids]

    def close(self) -> int | None:
        code = None
        try:
            if self.node_proc is not None:
                code = self.node_proc.stop()
        finally:
            self._stop_spinning()
            self.executor.shutdown()
            self.node.destroy_node()
            rclpy.shutdown(context=self.context)
            self.sim.close()
        return code
