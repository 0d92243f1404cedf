"""``dynamixel/save_servo_settings`` (std_srvs/Trigger): the servos' current settings written out as
a ``servos`` block to ``servos_snapshot.path`` (default: ``dynamixel_servos.yaml`` in the ROS log
directory), so that what an owner tuned live (``/dynamixel/command/gain`` ...) loads at the next
start.

The callback (an executor thread) only asks; the loop thread reads the servos after its next step
(the bus is the loop's) and writes the file; the answer names the file and the servos saved.
"""
from __future__ import annotations

import functools
import os
import threading
from pathlib import Path

import rclpy.logging
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

from ..servo_snapshot import entry_of, servos_yaml

#: the file's name in the ROS log directory when servos_snapshot.path is ""
DEFAULT_NAME = "dynamixel_servos.yaml"
#: longest wait for the loop to take the request [s]
WAIT_S = 10.0


class _Ask:
    def __init__(self) -> None:
        self.done = threading.Event()
        self.ok = False
        self.message = ""


class ServoSnapshot:
    """The service, and the step hook that answers it on the loop thread."""

    def __init__(self, node) -> None:
        from std_srvs.srv import Trigger
        self.node = node
        self._asked: list[_Ask] = []
        self._lock = threading.Lock()
        node.create_service(Trigger, "dynamixel/save_servo_settings", self._on_save,
                            callback_group=MutuallyExclusiveCallbackGroup())
        node.step_hooks.append(self.on_step)

    def path(self) -> Path:
        """servos_snapshot.path, or the default in the ROS log directory (a node in a namespace:
        ``dynamixel_servos_<namespace>.yaml``, so that the handlers of several buses keep theirs)."""
        given = self.node.settings.ros.snapshot_path
        if given:
            return Path(os.path.expanduser(given))
        space = self.node.get_namespace().strip("/").replace("/", "_")
        name = DEFAULT_NAME if not space else DEFAULT_NAME.replace(".yaml", f"_{space}.yaml")
        return Path(rclpy.logging.get_logging_directory()) / name

    def _on_save(self, _request, response):
        ask = _Ask()
        with self._lock:
            self._asked.append(ask)
        if not ask.done.wait(WAIT_S):
            ask.message = f"not saved: the bus loop did not take the request within {WAIT_S:g}s (is it running?)"
        response.success, response.message = ask.ok, ask.message
        (self.node.get_logger().info if ask.ok else self.node.get_logger().warning)(f"save_servo_settings: {ask.message}")
        return response

    def on_step(self, _report: object = None) -> None:
        """On the loop thread: each waiting request answered."""
        with self._lock:
            asked, self._asked = self._asked, []
        for ask in asked:
            try:
                ask.ok, ask.message = self.save()
            except Exception as exc:  # a file that cannot be written must not stop the loop
                ask.ok, ask.message = False, f"not saved: {type(exc).__name__}: {exc}"
            ask.done.set()

    def save(self) -> tuple[bool, str]:
        handler = self.node.handler
        ids = list(handler.handled_ids)
        if not ids:
            return False, "not saved: no servo is handled"
        entries = [(i, entry_of(handler.model(i), functools.partial(handler.read_item, i), handler.mode(i)))
                   for i in ids]
        path = self.path()
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(servos_yaml(entries, handler.bus.device), encoding="utf-8")
        return True, f"servos block of IDs {ids} written to {path}"


def attach(node) -> ServoSnapshot | None:
    """The service where std_srvs is installed (None, with one line, where it is not)."""
    try:
        import std_srvs.srv  # noqa: F401
    except ImportError as exc:
        node.get_logger().info(f"std_srvs is not available ({exc}): no dynamixel/save_servo_settings service")
        return None
    return ServoSnapshot(node)


__all__ = ["DEFAULT_NAME", "ServoSnapshot", "attach"]
