"""dynamixel_handler_lifecycle: each transition does what it says on the simulated servos."""
from __future__ import annotations

import os
import signal
import sys
import threading
import time

import rclpy
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelDebug, DynamixelShortcut
from dynamixel_handler_msgs.srv import SetTorque

from support.ros import CONFIG, PATIENT_SCAN, NodeProcess

X = 1020  # XM430-W350


def _command(device: str, *params: str) -> list[str]:
    exe = ([sys.executable, "-m", "dynamixel_handler.ros.lifecycle_node"] if os.environ.get("DXL_TEST_MODULE")
           else ["dynamixel_handler_lifecycle"])
    args = ["--ros-args", "--params-file", str(CONFIG)]
    # both servos required and the scan repeated until they answered: on a loaded machine one scan can
    # miss a reply of the simulator, and configure would then handle one servo
    for p in (f"device_name:={device}", "latency_timer:=1", "verbose_ratio:=0", "init/servo_auto_search.min_id:=1",
              "init/servo_auto_search.max_id:=2", "init/expected_servo_num:=2", PATIENT_SCAN,
              *params):
        args += ["-p", p]
    return exe + args


class Manager:
    """What a lifecycle manager does: change_state / get_state on the handler, and listen to it."""

    def __init__(self) -> None:
        rclpy.init()
        self.node = Node("lifecycle_test")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.change = self.node.create_client(ChangeState, "/dynamixel_handler/change_state")
        self.get = self.node.create_client(GetState, "/dynamixel_handler/get_state")
        self.debug: list[DynamixelDebug] = []
        self.node.create_subscription(DynamixelDebug, "/dynamixel/debug", self.debug.append, 20)
        self.position = self.node.create_publisher(DynamixelControlXPosition, "/dynamixel/command/x/position_control", 10)
        self.shortcut = self.node.create_publisher(DynamixelShortcut, "/dynamixel/shortcut", 10)
        self.torque = self.node.create_client(SetTorque, "/dynamixel/set_torque")
        self.lock = threading.Lock()
        self.running = True
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.running:
            with self.lock:
                self.executor.spin_once(timeout_sec=0.02)

    def _call(self, client, request):
        """The service's answer. ``wait_for_service`` says the server's request reader is there, not
        that the server has matched our reply reader yet: a request sent in between is answered
        into the void (DDS discovery, one direction at a time; seen once in a fresh-clone run, no
        answer in 30 s). Such a call is sent again after 10 s, up to three times, each logged."""
        assert client.wait_for_service(timeout_sec=20)
        for attempt in range(3):
            future = client.call_async(request)
            end = time.monotonic() + 10
            while not future.done() and time.monotonic() < end:
                time.sleep(0.02)
            if future.done():
                return future.result()
            print(f"lifecycle service: no answer in 10 s (attempt {attempt + 1}), sending again")
        raise AssertionError("no answer from the lifecycle service in three calls of 10 s")

    def transition(self, transition_id: int) -> bool:
        return self._call(self.change, ChangeState.Request(transition=Transition(id=transition_id))).success

    def state(self) -> int:
        return self._call(self.get, GetState.Request()).current_state.id

    def wait(self, predicate, what: str, proc: NodeProcess, timeout: float = 15.0) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return
            time.sleep(0.02)
        raise AssertionError(f"timed out waiting for {what}\n{proc.output[-4000:]}")

    def wait_quiet(self, gap: float, proc: NodeProcess, timeout: float = 10.0) -> None:
        """Wait until no /dynamixel/debug came for ``gap`` seconds."""
        seen = [len(self.debug), time.monotonic()]  # count, when it last changed

        def paused() -> bool:
            if len(self.debug) != seen[0]:
                seen[:] = [len(self.debug), time.monotonic()]
            return time.monotonic() - seen[1] >= gap
        self.wait(paused, "a pause in /dynamixel/debug", proc, timeout)

    def close(self) -> None:
        self.running = False
        self.thread.join(2)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()


def test_transitions_open_enable_disable_and_close_the_bus():
    sim = VirtualBus(servos={1: X, 2: X})
    proc = NodeProcess(_command(sim.start()))
    mgr = Manager()
    try:
        proc.wait_for("waiting for the configure transition", timeout=30)
        assert mgr.state() == State.PRIMARY_STATE_UNCONFIGURED
        assert sim.log == []  # an unconfigured handler leaves the bus alone

        # a stale goal far from where the shaft is: activation must not jump there
        stale = sim.servo(1).read("present_position") + 1000
        sim.servo(1).write("goal_position", stale)

        assert mgr.transition(Transition.TRANSITION_CONFIGURE)
        assert mgr.state() == State.PRIMARY_STATE_INACTIVE
        assert sim.log, "configure scans the bus"
        assert all(sim.servo(i).read("torque_enable") == 0 for i in (1, 2))  # torque untouched
        time.sleep(0.3)
        assert mgr.debug == []  # no loop while inactive

        assert mgr.transition(Transition.TRANSITION_ACTIVATE)
        assert mgr.state() == State.PRIMARY_STATE_ACTIVE
        assert all(sim.servo(i).read("torque_enable") == 1 for i in (1, 2))
        assert abs(sim.servo(1).read("goal_position") - sim.servo(1).read("present_position")) < 5  # goal := present
        mgr.wait(lambda: mgr.debug and len(mgr.debug[-1].status.id_list) == 2, "states while active", proc)
        mgr.wait(lambda: mgr.position.get_subscription_count() > 0, "the command subscription", proc)
        mgr.position.publish(DynamixelControlXPosition(id_list=[2], position_deg=[45.0]))
        mgr.wait(lambda: abs(mgr.debug[-1].position_deg.present[1] - 45.0) < 1.0, "commands work while active", proc)

        assert mgr.transition(Transition.TRANSITION_DEACTIVATE)
        assert mgr.state() == State.PRIMARY_STATE_INACTIVE
        assert all(sim.servo(i).read("torque_enable") == 0 for i in (1, 2))
        # messages of the last loops may still be on their way (late on a loaded machine): wait for a
        # pause in them (a running loop publishes every 10 ms and would never pause), then none may come
        mgr.wait_quiet(0.3, proc)
        n = len(mgr.debug)
        time.sleep(0.3)
        assert len(mgr.debug) == n  # loop stopped

        assert mgr.transition(Transition.TRANSITION_CLEANUP)
        assert mgr.state() == State.PRIMARY_STATE_UNCONFIGURED
        sim.clear_log()
        time.sleep(0.3)
        assert sim.log == []  # device closed, nothing sent

        # the whole way again: configure scans anew, activate switches torque on
        assert mgr.transition(Transition.TRANSITION_CONFIGURE)
        assert mgr.transition(Transition.TRANSITION_ACTIVATE)
        assert all(sim.servo(i).read("torque_enable") == 1 for i in (1, 2))
    finally:
        code = proc.stop(signal.SIGINT)
        mgr.close()
        sim.stop()
    assert code == 0, proc.output
    assert all(sim.servo(i).read("torque_enable") == 0 for i in (1, 2))  # term/torque_auto_disable on exit
    assert "Traceback" not in proc.output


def test_failed_configure_and_activate_leave_the_node_where_it_was():
    sim = VirtualBus(servos={1: X, 2: X})
    proc = NodeProcess(_command(sim.start(), "init/expected_servo_num:=2"))
    mgr = Manager()
    try:
        proc.wait_for("waiting for the configure transition", timeout=30)
        sim.set_silent(2, True)  # only one of the two expected servos answers
        assert not mgr.transition(Transition.TRANSITION_CONFIGURE)
        assert mgr.state() == State.PRIMARY_STATE_UNCONFIGURED
        proc.wait_for("configure failed: found 1 servo(s)")

        sim.set_silent(2, False)
        assert mgr.transition(Transition.TRANSITION_CONFIGURE)
        sim.set_silent(2, True)  # gone between configure and activate
        assert not mgr.transition(Transition.TRANSITION_ACTIVATE)
        assert mgr.state() == State.PRIMARY_STATE_INACTIVE
        assert sim.servo(1).read("torque_enable") == 0  # no half-enabled robot
        proc.wait_for("activate failed: torque on failed on IDs [2]")

        sim.set_silent(2, False)
        assert mgr.transition(Transition.TRANSITION_ACTIVATE)
        assert all(sim.servo(i).read("torque_enable") == 1 for i in (1, 2))
    finally:
        code = proc.stop(signal.SIGINT)
        mgr.close()
        sim.stop()
    assert code == 0, proc.output


def test_transitions_out_of_order_are_refused_and_the_node_keeps_running():
    sim = VirtualBus(servos={1: X, 2: X})
    proc = NodeProcess(_command(sim.start()))
    mgr = Manager()
    try:
        proc.wait_for("waiting for the configure transition", timeout=30)
        assert not mgr.transition(Transition.TRANSITION_ACTIVATE)  # not configured yet
        assert mgr.state() == State.PRIMARY_STATE_UNCONFIGURED
        proc.wait_for("transition 'activate' is not possible in state 'unconfigured'")
        assert sim.log == []  # nothing touched the bus

        assert mgr.transition(Transition.TRANSITION_CONFIGURE)
        assert not mgr.transition(Transition.TRANSITION_CONFIGURE)  # configure twice
        assert mgr.state() == State.PRIMARY_STATE_INACTIVE
        assert mgr.transition(Transition.TRANSITION_ACTIVATE)
        assert not mgr.transition(Transition.TRANSITION_CLEANUP)  # cleanup while active
        assert mgr.state() == State.PRIMARY_STATE_ACTIVE
        proc.wait_for("is not possible in state 'active'")
        mgr.wait(lambda: mgr.debug and len(mgr.debug[-1].status.id_list) == 2, "states while active", proc)
        assert proc.proc.poll() is None
    finally:
        code = proc.stop(signal.SIGINT)
        mgr.close()
        sim.stop()
    assert code == 0, proc.output
    assert "Traceback" not in proc.output and "RCLError" not in proc.output


def test_commands_while_inactive_are_dropped_not_replayed_at_activate():
    sim = VirtualBus(servos={1: X, 2: X})
    proc = NodeProcess(_command(sim.start()))
    mgr = Manager()
    try:
        proc.wait_for("waiting for the configure transition", timeout=30)
        assert mgr.transition(Transition.TRANSITION_CONFIGURE)
        where = sim.servo(2).read("present_position")
        mgr.wait(lambda: mgr.position.get_subscription_count() > 0, "the command subscription", proc)
        mgr.wait(lambda: mgr.shortcut.get_subscription_count() > 0, "the shortcut subscription", proc)
        # a move and, after it, a torque off: neither may happen at activate
        mgr.position.publish(DynamixelControlXPosition(id_list=[2], position_deg=[90.0]))
        mgr.shortcut.publish(DynamixelShortcut(command="TOFF", id_list=[1]))
        proc.wait_for("command(s) received while inactive dropped")

        # a service answers with a clear failure instead of waiting for a loop that does not run
        assert mgr.torque.wait_for_service(timeout_sec=20)
        answer = mgr._call(mgr.torque, SetTorque.Request(ids=[1], enable=True))
        assert not answer.success and "not active" in answer.message, answer.message
        assert sim.servo(1).read("torque_enable") == 0

        assert mgr.transition(Transition.TRANSITION_ACTIVATE)
        mgr.wait(lambda: mgr.debug and len(mgr.debug[-1].status.id_list) == 2, "states while active", proc)
        time.sleep(0.5)  # a replayed command would have landed by now
        assert all(sim.servo(i).read("torque_enable") == 1 for i in (1, 2))
        assert abs(sim.servo(2).read("goal_position") - where) < 5  # goal := present, not 90 deg
        assert abs(sim.servo(2).read("present_position") - where) < 5
        # while active, commands work as before
        mgr.position.publish(DynamixelControlXPosition(id_list=[2], position_deg=[45.0]))
        mgr.wait(lambda: abs(mgr.debug[-1].position_deg.present[1] - 45.0) < 1.0, "commands work while active", proc)
    finally:
        code = proc.stop(signal.SIGINT)
        mgr.close()
        sim.stop()
    assert code == 0, proc.output
