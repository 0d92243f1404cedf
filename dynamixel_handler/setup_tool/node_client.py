"""The set-up tool's line to a running handler node: ``dynamixel/get_items`` and
``dynamixel/set_items`` called with rclpy (imported only on this path: the tool is ROS-free
otherwise), on the node's ROS domain from its owner record, with the user's ROS environment
otherwise. Every call has a deadline: a node that does not answer is one line (StepFailed, exit 1),
never a hang."""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Any, Sequence

import rclpy
from rclpy.executors import SingleThreadedExecutor

from dynamixel_handler_msgs.srv import GetItems, RebootServos, SetItems

from ..bus.owner_record import Owner
from .errors import StepFailed

__all__ = ["Entry", "NodeClient", "FIND_S"]

#: how long the node's services are looked for (discovery) [s]
FIND_S = 5.0
#: time allowed beyond the node's own deadline for a request (its loop answers within 5 s, 50 ms a pair) [s]
SLACK_S = 3.0
#: the node's time per servo of a reboot (it waits up to 1 s for the servo, then sets it up) [s]
REBOOT_S = 2.0


@dataclass(frozen=True)
class Entry:
    """One servo's item as the node answered it."""

    dxl_id: int
    item: str
    #: the register value (None: not read, or not written as asked: ``error`` says why)
    raw: int | None
    error: str


class NodeClient:
    """A short-lived rclpy node of the tool's own that calls the handler ``owner``'s services."""

    def __init__(self, owner: Owner) -> None:
        self.owner = owner
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=owner.domain_id)
        self.node = rclpy.create_node(f"dynamixel_handler_setup_{os.getpid()}", context=self.context,
                                      start_parameter_services=False, enable_rosout=False)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients: dict[str, Any] = {}

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()  # type: ignore[no-untyped-call]
        self.context.try_shutdown()

    def service(self, name: str) -> str:
        return f"{self.owner.namespace.rstrip('/')}/dynamixel/{name}"

    def _call(self, kind: Any, name: str, request: Any, pairs: int, per_pair_s: float = 0.05) -> Any:
        full = self.service(name)
        client = self._clients.get(full)
        if client is None:
            client = self._clients[full] = self.node.create_client(kind, full)
        if not client.wait_for_service(timeout_sec=FIND_S):
            raise StepFailed(f"the running node {self.owner.node} (pid {self.owner.pid}) does not offer {full} within "
                             f"{FIND_S:g} s (another ROS domain or discovery range than this shell's? "
                             f"ROS_DOMAIN_ID {self.owner.domain_id} is the node's); stop it to use the port directly")
        future = client.call_async(request)
        deadline = 5.0 + per_pair_s * pairs + SLACK_S
        self.executor.spin_until_future_complete(future, timeout_sec=deadline)
        if not future.done():
            client.remove_pending_request(future)
            raise StepFailed(f"the running node {self.owner.node} did not answer {full} within {deadline:g} s")
        res = future.result()
        if len(res.errors) != pairs:  # refused or failed as a whole (the adapter gone, the loop late)
            raise StepFailed(f"the running node {self.owner.node}: {name}: {res.message}")
        return res

    def handled(self) -> list[int]:
        """The IDs the node handles, from its latched ``dynamixel/manifest`` (one status per servo)."""
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        got: list[Any] = []
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,  # type: ignore[no-untyped-call]
                         reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        sub = self.node.create_subscription(DiagnosticArray, self.service("manifest"), got.append, qos)
        end = time.monotonic() + FIND_S
        while not got and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.1)
        self.node.destroy_subscription(sub)
        if not got:
            raise StepFailed(f"the running node {self.owner.node} published no {self.service('manifest')} within "
                             f"{FIND_S:g} s: give the IDs")
        return sorted(int(s.hardware_id.split()[-1]) for s in got[-1].status if s.hardware_id.startswith("ID "))

    def switch_modes(self, ids: Sequence[int], mode: str) -> None:
        """Ask the node to switch the servos ``ids`` to ``mode`` (a status command's ``mode`` on
        ``dynamixel/commands/all``: the node's own mode change, goals and torque handled)."""
        from dynamixel_handler_msgs.msg import DxlCommandsAll, DynamixelStatus

        topic = self.service("commands/all")
        pub = self.node.create_publisher(DxlCommandsAll, topic, 10)
        end = time.monotonic() + FIND_S
        while pub.get_subscription_count() == 0 and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        if pub.get_subscription_count() == 0:
            raise StepFailed(f"the running node {self.owner.node} does not listen on {topic} within {FIND_S:g} s")
        pub.publish(DxlCommandsAll(status=DynamixelStatus(id_list=list(ids), mode=[mode] * len(ids))))

    def get(self, ids: Sequence[int], items: Sequence[str]) -> tuple[Any, list[Entry]]:
        """The node's answer and its entries (one per servo and item)."""
        res = self._call(GetItems, "get_items", GetItems.Request(ids=list(ids), items=list(items)), len(ids) * len(items))
        return res, _entries(res)

    def set(self, ids: Sequence[int], items: Sequence[str], raw: Sequence[int], force: bool,
            torque_off: bool) -> tuple[Any, list[Entry]]:
        """Register values (one per servo and item) written and read back by the node."""
        req = SetItems.Request(ids=list(ids), items=list(items), values=[float(v) for v in raw], raw=True,
                               force=force, torque_off=torque_off)
        res = self._call(SetItems, "set_items", req, len(ids) * len(items))
        return res, _entries(res)

    def reboot(self, ids: Sequence[int], torque_off: bool) -> Any:
        """The named servos rebooted by the node (``dynamixel/reboot_servos``): its answer, one entry
        per servo (``id_list``, ``torque_on``, ``errors``)."""
        req = RebootServos.Request(ids=list(ids), torque_off=torque_off)
        return self._call(RebootServos, "reboot_servos", req, len(ids), REBOOT_S)


def _entries(res: Any) -> list[Entry]:
    """The entries; ``raw`` None where the node says why the item was not read or written as asked."""
    return [Entry(int(i), str(n), None if e else int(r), str(e))
            for i, n, r, e in zip(res.id_list, res.item_list, res.raw, res.errors)]
