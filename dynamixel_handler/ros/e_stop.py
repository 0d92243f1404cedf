"""The E-stop's doors: topic ``dynamixel/e_stop`` (``std_msgs/Bool``: true engages, false
releases), service ``dynamixel/set_e_stop`` (``std_srvs/SetBool``) and the latched state
``dynamixel/e_stop_state`` (``std_msgs/Bool``, transient local, depth 1: a tool that starts late
gets it at once).

The doors only hand ``EngageStop`` / ``ReleaseStop`` requests to the loop thread
(``core.e_stop``). The service answers once the loop has taken the request (within a loop or two,
at most ``ANSWER_WITHIN_S``), so a caller that moves right after a release is not refused; a
release while a servo is still in error with ``safety/on_hardware_error: hold_all`` is answered
``success: false`` with the servos named."""
from __future__ import annotations

import threading
import time

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from ..core.request_types import EngageStop, ReleaseStop
from ..logs import Throttle

#: the latched state: the last value is kept for subscribers that come later
STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: longest wait of the service for the loop to take the request [s]
ANSWER_WITHIN_S = 2.0


class EStopDoors:
    """The topic, the service and the state publisher of one node."""

    def __init__(self, node) -> None:
        self.node = node
        self.e_stop = node.handler.e_stop
        self.log = node.get_logger()
        self.warn = Throttle(self.log.warning)
        self._seen = -1  # e_stop.changes last published
        self._taken = threading.Condition()
        self.pub = node.create_publisher(Bool, "dynamixel/e_stop_state", STATE_QOS)
        group = ReentrantCallbackGroup()
        node.create_subscription(Bool, "dynamixel/e_stop", self._on_topic, 10, callback_group=group)
        node.create_service(SetBool, "dynamixel/set_e_stop", self._on_service, callback_group=group)
        self._publish()

    def _on_topic(self, msg: Bool) -> None:
        self._ask(bool(msg.data), "dynamixel/e_stop")

    def _ask(self, engage: bool, door: str) -> None:
        self.node.handler.submit(EngageStop(door) if engage else ReleaseStop(door))

    def _on_service(self, req: SetBool.Request, res: SetBool.Response) -> SetBool.Response:
        engage = bool(req.data)
        if not engage:
            refused = self.e_stop.release_refusal()
            if refused is not None:
                res.success, res.message = False, refused
                self.warn(f"set_e_stop: {refused}")
                return res
        if self.node.loop_stopped:
            res.success, res.message = False, "the bus loop stopped: nothing can be held or released"
            return res
        self._ask(engage, "dynamixel/set_e_stop")
        deadline = time.monotonic() + ANSWER_WITHIN_S
        with self._taken:
            while (self.e_stop.engaged_why() is not None) != engage:
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._taken.wait(min(left, 0.05))
        why = self.e_stop.engaged_why()
        if (why is not None) != engage:
            refused = self.e_stop.release_refusal() if not engage else None
            res.success = False
            res.message = refused or f"the loop did not take the request within {ANSWER_WITHIN_S:g} s"
        elif engage:
            res.success, res.message = True, f"E-stop engaged ({why}): every servo holds where it is"
        else:
            res.success, res.message = True, "E-stop released: commands are taken again; nothing moved"
        return res

    # ------------------------------------------------------------------ loop thread
    def __call__(self, _report: object = None) -> None:
        """Step hook: the state published when it changed; a waiting service call woken."""
        if self.e_stop.changes != self._seen:
            self._publish()
            with self._taken:
                self._taken.notify_all()

    def _publish(self) -> None:
        self._seen = self.e_stop.changes
        self.pub.publish(Bool(data=self.e_stop.engaged_why() is not None))


def attach(node) -> EStopDoors:
    return EStopDoors(node)
