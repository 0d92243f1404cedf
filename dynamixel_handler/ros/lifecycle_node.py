"""The handler as a managed (lifecycle) node: ``dynamixel_handler_lifecycle``.

Same parameters, topics, services and action as ``dynamixel_handler``, but the bus is only
touched when a manager (launch, nav2's lifecycle_manager, ``ros2 lifecycle set``) says so:

- configure: open the device, scan and set up the servos (torque stays as it is);
- activate: for each servo goal := present state, then torque on (no jump), and start the loop;
- deactivate: stop the loop, torque off;
- cleanup: forget the servos and close the device;
- shutdown (or SIGINT/SIGTERM): stop the loop and leave the servos safe as ``term/*`` say.

A configure that finds no servo (or no device) fails and the node stays unconfigured; an activate
that cannot switch on every servo switches the others back off and fails, so the node stays
inactive; an unexpected error goes through error processing, which leaves the servos without
torque and the device closed (unconfigured).
"""
from __future__ import annotations

import sys
import time
from typing import Callable

from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from ..bus import BusError
from ..core.handler import StartupError
from . import fastpath
from .node import DynamixelHandlerNode, run

SUCCESS, FAILURE, ERROR = (TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE,
                           TransitionCallbackReturn.ERROR)
#: transition id -> name, for log lines ("activate", "unconfigured_shutdown", ...)
TRANSITION_NAMES = {getattr(Transition, n): n[len("TRANSITION_"):].lower() for n in dir(Transition)
                    if n.startswith("TRANSITION_") and isinstance(getattr(Transition, n), int)}
#: how often commands that arrive while the loop does not run are taken and dropped [s]
DRAIN_PERIOD_S = 0.2
#: least time between two warnings about commands dropped while not active [s]
DROP_WARN_INTERVAL_S = 1.0


class DynamixelHandlerLifecycleNode(DynamixelHandlerNode, LifecycleNode):
    """DynamixelHandlerNode whose bus work follows the lifecycle transitions."""

    def __init__(self, interrupted: Callable[[], bool] = lambda: False) -> None:
        super().__init__(interrupted)  # parameters, publishers, subscriptions, services; no bus access
        # torque comes on at activate, not during the configure scan
        self.handler.settings = self.settings.but(scan__torque_auto_enable=False)
        # a transition the state machine does not have from the current state (activate while
        # unconfigured, configure twice) fails with an answer, not an exception in the executor
        if not fastpath.lifecycle_guard(self, self._guarded_change_state):
            self.get_logger().debug("change_state: this rclpy's LifecycleNode hides its state machine: "
                                    "transitions out of order are refused by rclpy itself")
        # commands that arrive while the loop does not run are dropped (with a warning), never
        # kept for activate; services and the action answer at once
        self.handler.refuse_ops = "the node is not active (lifecycle state unconfigured): configure and activate it"
        self._dropped, self._drop_warned = 0, 0.0
        self.create_timer(DRAIN_PERIOD_S, self._drain_commands)

    # ------------------------------------------------------------------ guards
    def _guarded_change_state(self, serve, state, transitions):
        def change_state(req: ChangeState.Request, res: ChangeState.Response) -> ChangeState.Response:
            label = state()
            allowed = {t[0]: t[1] for t in transitions()}
            asked = req.transition.label or TRANSITION_NAMES.get(req.transition.id, str(req.transition.id))
            if (req.transition.label and req.transition.label not in allowed.values()) or \
                    (not req.transition.label and req.transition.id not in allowed):
                self.get_logger().warning(
                    f"change_state: transition '{asked[:80]}' is not possible in state '{label}' "
                    f"(possible: {', '.join(allowed.values()) or 'none'}): refused, staying {label}")
                res.success = False
                return res
            try:
                return serve(req, res)
            except fastpath.RCLError as err:  # the state machine refused it after all
                self.get_logger().warning(f"change_state: transition '{asked[:80]}' refused in state '{label}': "
                                          f"{str(err).splitlines()[0][:120]}")
                res.success = False
                return res
        return change_state

    def _drain_commands(self) -> None:
        """While the loop does not run: take the waiting command messages and drop them, with one
        warning line a second at most (a servo must not move, or lose torque, at activate because
        of a command sent while the node was inactive)."""
        if self.loop_running:
            return
        dropped = self.intake.discard() + self.handler.drop_ops()
        if not dropped:
            return
        self._dropped += dropped
        now = time.monotonic()
        if now - self._drop_warned >= DROP_WARN_INTERVAL_S:
            state = fastpath.lifecycle_state(self)
            self.get_logger().warning(f"{self._dropped} command(s) received while {state} dropped "
                                      "(commands apply only while active)")
            self._dropped, self._drop_warned = 0, now

    # ------------------------------------------------------------------ transitions
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            self.open_and_scan()
        except (BusError, StartupError) as err:
            self.get_logger().error(f"configure failed: {err}")
            self._forget_and_close()
            return FAILURE
        except Exception as exc:
            self.get_logger().error(f"configure: {type(exc).__name__}: {exc}")
            return ERROR
        self.get_logger().info(f"configured: servos {list(self.handler.table.ids)} (torque unchanged)")
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            ids = list(self.handler.table.ids)
            enabled = {i: self.handler.core.torque_on(i) for i in ids}  # goal := present, then torque on
            failed = [i for i, done in enabled.items() if not done]
            if failed:
                for i in ids:
                    self.handler.core.torque_off(i)
                self.get_logger().error(f"activate failed: torque on failed on IDs {failed}: "
                                        f"{enabled[failed[-1]].failure} (all servos left without torque)")
                return FAILURE
            self._drain_commands()  # nothing sent while inactive is replayed now
            self.start_loop()
            self.handler.refuse_ops = None
        except Exception as exc:
            self.get_logger().error(f"activate: {type(exc).__name__}: {exc}")
            return ERROR
        self.get_logger().info(f"active: torque on for IDs {ids}, loop running")
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            self._stop_loop()
            disabled = {i: self.handler.core.torque_off(i) for i in self.handler.table.ids}
            failed = [i for i, done in disabled.items() if not done]
        except Exception as exc:
            self.get_logger().error(f"deactivate: {type(exc).__name__}: {exc}")
            return ERROR
        if failed:
            self.get_logger().warning(f"deactivate: torque off failed on IDs {failed}: {disabled[failed[-1]].failure}")
        self.get_logger().info("inactive: loop stopped, torque off")
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._forget_and_close()
        self.get_logger().info("cleaned up: device closed")
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        configured, ids = self.wire.is_open, list(self.handler.table.ids)
        self._safe_stop()
        if configured:
            safety = [k for k in ("term/servo_auto_stop", "term/torque_auto_disable") if self.config[k]]
            self.get_logger().info(f"shut down: loop stopped, IDs {ids} left as {', '.join(safety) or 'they were'}, "
                                   "device closed")
        else:
            self.get_logger().info("shut down: nothing was configured")
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Leave the servos without torque and the device closed; back to unconfigured."""
        self._stop_loop()
        try:
            if self.wire.is_open:
                for i in list(self.handler.table.ids):
                    self.handler.core.torque_off(i)
        except Exception as exc:
            self.get_logger().error(f"error processing: torque off: {type(exc).__name__}: {exc}")
        self._forget_and_close()
        self.get_logger().warning("error processing done: torque off, device closed (unconfigured)")
        return SUCCESS

    # ------------------------------------------------------------------ helpers
    def _stop_loop(self) -> None:
        self.handler.refuse_ops = "the node is not active (lifecycle): activate it first"
        self.stop_loop()

    def _forget_and_close(self) -> None:
        self._stop_loop()
        for i in list(self.handler.table.ids):
            self.handler.table.remove(i)
        self.handler.pending.take()
        self.close_wire()

    def _safe_stop(self) -> None:
        """The node's stop(): loop stopped, servos safe as term/* say, device closed (idempotent)."""
        self.stop()


def main(args: list[str] | None = None) -> int:
    def ready(node: DynamixelHandlerLifecycleNode) -> None:
        node.get_logger().info("unconfigured: waiting for the configure transition")
    return run(DynamixelHandlerLifecycleNode, ready, args)

if __name__ == "__main__":
    sys.exit(main())
