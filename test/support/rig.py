"""The test rig: a virtual bus, the real node process on it, and an rclpy node in the test process
that publishes commands and keeps every message the handler publishes.

Nothing of ours is replaced: the node is the installed console script, the bus is a pty served by
the virtual bus, and the messages travel through real DDS on this test run's own domain.
"""
from __future__ import annotations

import shutil
import tempfile
import threading
import time
from typing import Callable, Iterable, Iterator, Sequence

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from dynamixel_handler.protocol import FAST_SYNC_READ, PING, READ, SYNC_READ, SYNC_WRITE, WRITE
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import (
    DxlStates,
    DynamixelDebug,
    DynamixelError,
    DynamixelExtra,
    DynamixelGain,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelPresent,
    DynamixelStatus,
)

from .ros import PATIENT_SCAN, NodeProcess, TopicClient, node_command
from .sim_process import SimProcess

__all__ = ["BASE_PARAMS", "FAST_SYNC_READ", "FOUR_SERVOS", "H54", "P", "PH54", "PING", "PRO", "READ", "Received",
           "Rig", "STATE_TOPICS", "SYNC_READ", "SYNC_WRITE", "WRITE", "X", "X540", "XM430", "XM540"]

#: XM430-W350, XM540-W270, PH54-200-S500-R, H54-200-S500-R (old Pro firmware)
X, X540, P, PRO = 1020, 1120, 2020, 54024
XM430, XM540, PH54, H54 = X, X540, P, PRO
FOUR_SERVOS = {1: XM430, 2: XM540, 3: PH54, 4: H54}

STATE_TOPICS = {
    "status": DynamixelStatus, "present": DynamixelPresent, "goal": DynamixelGoal, "gain": DynamixelGain,
    "limit": DynamixelLimit, "error": DynamixelError, "extra": DynamixelExtra,
}

#: the handler-core tests' parameters (``base=BASE_PARAMS``): a fast adapter, 100 Hz, every
#: series on, IDs 0..6 searched, quiet unless a test asks
BASE_PARAMS = ("latency_timer:=1", "loop_rate:=100", "verbose_ratio:=0", "init/used_servo_series.X:=true",
               "init/used_servo_series.P:=true", "init/used_servo_series.Pro:=true",
               "init/servo_auto_search.min_id:=0", "init/servo_auto_search.max_id:=6")


def turn_by_hand(sim: VirtualBus, dxl_id: int, pulses: float) -> None:
    """Turn the shaft of a servo as a hand would (no instruction on the bus): the virtual servo has
    no public hook for an external force, so the motor model is moved directly. Meant for a servo
    with torque off (with torque on it would just drive back)."""
    with sim._lock:
        servo = sim.servo(dxl_id)
        servo.refresh(servo._clock())
        servo._motor.p += pulses
        servo.refresh(servo._clock())


def power_cycle(sim: VirtualBus, dxl_id: int) -> None:
    """Switch a virtual servo off and on again: RAM at its defaults, torque off, a multi-turn
    position folded into one turn."""
    with sim._lock:
        servo = sim.servo(dxl_id)
        servo.reboot(servo._clock())


def scan_params(servos: Iterable[int], expect: int) -> tuple[str, ...]:
    """The default parameters: a fast adapter, P and Pro on, exactly the IDs of ``servos`` searched,
    ``expect`` of them required, quiet. A loaded machine can delay the simulator's reply past a 1 ms
    adapter's timeout: the scan retries until every servo was seen (``PATIENT_SCAN``)."""
    ids = sorted(servos)
    return ("latency_timer:=1", "init/used_servo_series.P:=true", "init/used_servo_series.Pro:=true",
            f"init/servo_auto_search.min_id:={ids[0]}", f"init/servo_auto_search.max_id:={ids[-1]}",
            PATIENT_SCAN, f"init/expected_servo_num:={expect}", "verbose_ratio:=0")


class Received:
    """Messages of one topic in arrival order, with their arrival time (monotonic). Reads like a
    list of the messages (``len``, ``[-1]``, slices, iteration) and is safe to read while the
    spinning thread appends."""

    def __init__(self) -> None:
        self._items: list[tuple[float, object]] = []
        self._lock = threading.Lock()

    def add(self, msg: object) -> None:
        with self._lock:
            self._items.append((time.monotonic(), msg))

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)

    def __getitem__(self, index):
        return self.all()[index]

    def __iter__(self) -> Iterator:
        return iter(self.all())

    def __reversed__(self) -> Iterator:
        return reversed(self.all())

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


class Rig(TopicClient):
    """A virtual bus, a listening rclpy node (a context of its own: rigs may overlap), then the
    handler node process on the bus.

    ``servos``: ``{id: model number}`` on the bus (default: one XM430, XM540, PH54 and H54).
    ``params``: ``name:=value`` for the node, after the ``base`` ones (default :func:`scan_params`).
    ``expect``: number of IDs the node should handle (default: every simulated servo);
    ``wait_ids``: instead, the exact IDs the first ``/dynamixel/debug`` must list.
    ``sim_kwargs``: for the ``VirtualBus`` (its replies are untimed unless ``wire_timing`` is asked);
    ``before_start``: called with the bus before the node starts; ``env``: extra environment of the
    node process; ``state_topics``: also keep ``/dynamixel/state/<group>`` (``topics["state/..."]``);
    ``start_node``: False to start the node later with :meth:`start_node`.
    ``sim_env``: serve the bus from a ``dynamixel_handler_sim`` process with this environment added
    (a family plug-in on its path, ``support.sim_process``): ``rig.sim`` is then a ``SimProcess``
    (its run-time commands), not a ``VirtualBus`` (no registers, no instruction log here).

    The node opens the bus through a link in a folder of the rig's own (unless ``sim_kwargs`` names
    one): a node that lost a bare ``/dev/pts/N`` (``sim.vanish()``) opens it again as soon as the
    number is free, and with tests running side by side another test's bus may be given that number.
    """

    def __init__(self, servos: dict[int, int] | None = None, *params: str, base: Sequence[str] | None = None,
                 sim_kwargs: dict | None = None, expect: int | None = None, wait_ids: Iterable[int] | None = None,
                 before_start: Callable[[VirtualBus], None] | None = None, env: dict[str, str] | None = None,
                 state_topics: bool = False, start_node: bool = True, sim_env: dict[str, str] | None = None) -> None:
        self.env = env
        # the servos as unboxed (57600 bps, the node's default; answering only at that rate), but
        # untimed replies: wire timing is opted into per test (``sim_kwargs``)
        servos = dict(FOUR_SERVOS if servos is None else servos)
        self.servo_ids = sorted(servos)
        self._link_dir = None if "link" in (sim_kwargs or {}) else tempfile.mkdtemp(prefix="dxl-rig-")
        link = {} if self._link_dir is None else {"link": f"{self._link_dir}/ttyDXL"}
        if sim_env is None:
            self.sim = VirtualBus(servos=servos, **{"wire_timing": False, **link, **(sim_kwargs or {})})
        else:
            self.sim = SimProcess(servos, link["link"], sim_env)
        self.device = self.sim.start()
        self._base = base
        self.node_proc: NodeProcess | None = None
        # listen first, so the node's first loops reach us once discovery is done
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node(f"test_rig_{id(self):x}", context=self.context)
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.topics: dict[str, Received] = {}
        names = [("states", DxlStates), ("debug", DynamixelDebug)]
        if state_topics:
            names += [(f"state/{g}", t) for g, t in STATE_TOPICS.items()]
        for name, typ in names:
            self.topics[name] = Received()
            self.node.create_subscription(typ, f"/dynamixel/{name}", self.topics[name].add, qos)
        #: every /dynamixel/states and /dynamixel/debug message, in arrival order
        self.states, self.debug = self.topics["states"], self.topics["debug"]
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._start_spinning()
        try:
            if before_start is not None:
                before_start(self.sim)
            if start_node:
                self.start_node(*params, expect=expect, wait_ids=wait_ids)
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ node process
    def start_node(self, *params: str, expect: int | None = None, wait_ids: Iterable[int] | None = None) -> None:
        """Start the handler on the bus and wait for its first ``/dynamixel/debug`` with every
        servo (``expect`` of them, or exactly ``wait_ids``)."""
        n = len(self.servo_ids) if expect is None else expect
        base = scan_params(self.servo_ids, n) if self._base is None else self._base
        self.node_proc = NodeProcess(node_command(f"device_name:={self.device}", *base, *params), env=self.env)
        if wait_ids is not None:
            ids = sorted(wait_ids)
            self.wait(lambda: (m := self.debug.last()) is not None and list(m.status.id_list) == ids,
                      timeout=30, what=f"/dynamixel/debug with IDs {ids}")
            return
        self.node_proc.wait_for("handled", timeout=30)
        self.wait(lambda: (m := self.debug.last()) is not None and len(m.status.id_list) == n
                  and len(m.position_deg.present) == n, timeout=30, what="the first /dynamixel/debug with every servo")

    def stop_node(self, sig=None) -> int:
        """Stop the node (SIGINT unless told) and return its exit code."""
        assert self.node_proc is not None
        return self.node_proc.stop() if sig is None else self.node_proc.stop(sig)

    @property
    def output(self) -> str:
        return self.node_proc.output if self.node_proc is not None else ""

    # ------------------------------------------------------------------ the node's log
    def mark(self) -> int:
        """A position in the node's log; ``log_since``/``wait_log`` look only at what came after."""
        return len(self.node_proc.lines)

    def log_since(self, mark: int) -> str:
        return "\n".join(self.node_proc.lines[mark:])

    def warnings_since(self, mark: int, about: Iterable[int] = ()) -> list[str]:
        """The WARN lines after ``mark``, but for "no response (ping false)" of servos other than
        ``about``: a loaded machine can hold the simulator's reply back past the node's short wait
        (latency_timer 1), and that warning then comes and goes whatever the test does."""
        keep = {f"ID {i}: " for i in about}
        return [line for line in self.log_since(mark).splitlines() if "WARN" in line
                and ("no response (ping false)" not in line or any(k in line for k in keep))]

    def wait_log(self, *substrings: str, since: int = 0, timeout: float = 10.0) -> str:
        """Wait until one line after ``since`` holds every one of ``substrings``; that line."""
        found: list[str] = []

        def seen() -> bool:
            found[:] = [line for line in self.node_proc.lines[since:] if all(s in line for s in substrings)]
            return bool(found)
        self.wait(seen, timeout=timeout, what=f"a log line with {substrings!r}")
        return found[0]

    # ------------------------------------------------------------------ topics
    def debug_of(self, dxl_id: int) -> dict:
        """Latest debug values of one ID: present/goal of position, velocity, current; torque; mode."""
        msg = self.debug[-1]
        k = list(msg.status.id_list).index(dxl_id)
        return {"position": msg.position_deg.present[k], "goal_position": msg.position_deg.goal[k],
                "velocity": msg.velocity_deg_s.present[k], "goal_velocity": msg.velocity_deg_s.goal[k],
                "current": msg.current_ma.present[k], "goal_current": msg.current_ma.goal[k],
                "torque": msg.status.torque[k], "mode": msg.status.mode[k], "error": msg.status.error[k],
                "ping": msg.status.ping[k]}

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

    def wait_new(self, topics: Iterable[str], count: int, timeout: float = 10.0) -> float:
        """Wait until each topic delivered ``count`` messages from now on; return the start time."""
        start = time.monotonic()
        for topic in topics:
            self.wait(lambda: len(self.topics[topic].since(start)) >= count, timeout=timeout,
                      what=f"{count} new messages on /dynamixel/{topic}")
        return start

    # ------------------------------------------------------------------ the bus
    def turn_by_hand(self, dxl_id: int, pulses: float) -> None:
        """Turn the shaft of a servo as a hand would (``turn_by_hand``)."""
        turn_by_hand(self.sim, dxl_id, pulses)

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
        """Stop the node (its exit code; None if it was never started), the listener and the bus."""
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
            if self._link_dir is not None:
                shutil.rmtree(self._link_dir, ignore_errors=True)
        return code
