"""A defect in one callback does not end the node: the node's executor thread (``ros.process``)
says it in one error line a second per cause, the traceback at debug level, and keeps serving every
other callback. Real rclpy, a real executor, a real node with a callback that raises."""
from __future__ import annotations

import threading
import time

import rclpy
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from dynamixel_handler.ros.process import _Spinner


class Lines:
    """A logger that keeps its lines (the node's rcutils logger's interface)."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def error(self, msg: str) -> None:
        self.lines.append(("error", msg))

    def fatal(self, msg: str) -> None:
        self.lines.append(("fatal", msg))

    def debug(self, msg: str) -> None:
        self.lines.append(("debug", msg))


def test_a_callback_that_raises_is_one_line_a_second_and_the_others_go_on():
    context = rclpy.Context()  # its own: the process's default context is not to be shut down
    rclpy.init(context=context)
    try:
        node = Node("callback_defect", context=context)
        good = []
        node.create_timer(0.01, lambda: good.append(time.monotonic()))
        node.create_timer(0.01, lambda: 1 / 0)  # a defect, every 10 ms
        executor = MultiThreadedExecutor(num_threads=2, context=context)
        executor.add_node(node)
        stopping, log = threading.Event(), Lines()
        spinner = _Spinner(executor, stopping, lambda: None, log)
        deadline = time.monotonic() + 30
        while len(good) < 150 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert spinner.thread.is_alive() and not stopping.is_set()
        errors = [m for level, m in log.lines if level == "error"]
        assert errors and errors[0].startswith("a callback failed (the node goes on): ZeroDivisionError: division by zero")
        assert len(errors) <= 1 + (good[-1] - good[0]), errors  # one a second
        assert any("Traceback" in m for level, m in log.lines if level == "debug")
        stopping.set()
        spinner.join()  # nothing raised on the main thread
        executor.shutdown()
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
