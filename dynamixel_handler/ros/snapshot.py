"""``dynamixel/save_servo_settings`` (std_srvs/Trigger): the servos' current settings written out as
a ``servos`` block to ``servos_snapshot.path`` (default: ``dynamixel_servos.yaml`` in the ROS log
directory), so that what an owner tuned live (``/dynamixel/command/gain`` ...) loads at the next
start.

One save at a time: a call while one runs is answered at once, "busy". The path is checked before
anything is read: a regular file or a new one in an existing folder; a symbolic link (not
followed), a FIFO, a device (the bus's own included), a folder are refused. The loop thread only
reads the values, after its next step, one sync read per control-table layout (the bus is the
loop's); the service's thread turns them into the file, written to a temporary file in the same
folder and renamed over the old one (a reader never sees half a file). The answer names the file
and the servos saved.
"""
from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

import rclpy.logging
from rclpy.callback_groups import ReentrantCallbackGroup

from ..logs import cut_path
from ..servo.snapshot import entry_of, items_of, servos_yaml
from .files import refusal, write_atomically
from .services import QOS

#: the file's name in the ROS log directory when servos_snapshot.path is ""
DEFAULT_NAME = "dynamixel_servos.yaml"
#: longest wait for the loop to take the request [s]
WAIT_S = 10.0

class _Ask:
    """One save: taken by the loop (``values`` filled), answered by the service's thread."""

    def __init__(self) -> None:
        self.taken = threading.Event()
        self.values: dict[int, tuple[Any, str | None, dict[str, int]]] = {}
        #: handled servos that did not answer (left out of the file)
        self.missing: list[int] = []
        self.error = ""


class ServoSnapshot:
    """The service, and the step hook that reads the values on the loop thread."""

    def __init__(self, node) -> None:
        from std_srvs.srv import Trigger
        self.node = node
        self._asked: _Ask | None = None
        self._lock = threading.Lock()
        self._saving = threading.Lock()  # one save at a time
        node.create_service(Trigger, "dynamixel/save_servo_settings", self._on_save, qos_profile=QOS,
                            callback_group=ReentrantCallbackGroup())  # a burst of calls answered, busy or not
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
        if not self._saving.acquire(blocking=False):
            response.success = False
            response.message = "busy: a save is in progress (one at a time); call again when it has answered"
            return response
        try:
            response.success, response.message = self._save()
        except Exception as exc:  # a file that cannot be written is an answer, not a dead service
            response.success, response.message = False, f"not saved: {type(exc).__name__}: {cut_path(exc)}"
        finally:
            self._saving.release()
        # one call site per severity: rclpy refuses a call site whose severity changes between calls
        if response.success:
            self.node.get_logger().info(f"save_servo_settings: {response.message}")
        else:
            self.node.get_logger().warning(f"save_servo_settings: {response.message}")
        return response

    def _save(self) -> tuple[bool, str]:
        path = self.path()
        if not self.node.settings.ros.snapshot_path:
            path.parent.mkdir(parents=True, exist_ok=True)  # the ROS log directory: ours to make
        device = self.node.handler.bus.device
        why = refusal(path, device)
        if why:
            return False, f"not saved: servos_snapshot.path {cut_path(path)} {why}"
        ask = _Ask()
        with self._lock:
            self._asked = ask
        if not ask.taken.wait(WAIT_S):
            with self._lock:
                untaken = self._asked is ask
                self._asked = None
            if untaken:
                return False, f"not saved: the bus loop did not take the request within {WAIT_S:g}s (is it running?)"
            ask.taken.wait()
        if ask.error or not ask.values:
            return False, f"not saved: {ask.error or 'no servo answered'}"
        ids = sorted(ask.values)
        entries = [(i, entry_of(model, values.get, mode)) for i, (model, mode, values) in sorted(ask.values.items())]
        why = refusal(path, device)  # again: the file may have been replaced meanwhile
        if why:
            return False, f"not saved: servos_snapshot.path {cut_path(path)} {why}"
        write_atomically(path, servos_yaml(entries, device))
        missing = f" (IDs {ask.missing} did not answer: left out)" if ask.missing else ""
        return True, f"servos block of IDs {ids} written to {cut_path(path)}{missing}"

    def on_step(self, _report: object = None) -> None:
        """On the loop thread: the values of a waiting save, read at once."""
        with self._lock:
            ask, self._asked = self._asked, None
        if ask is None:
            return
        try:
            handler = self.node.handler
            ids = list(handler.handled_ids)
            models = {i: handler.model(i) for i in ids}
            wanted = sorted({item for model in models.values() for item in items_of(model)})
            read = handler.group.read_items(wanted, ids)  # one sync read per layout and span
            ask.values = {i: (models[i], handler.mode(i), read[i]) for i in ids if i in read}
            ask.missing = [i for i in ids if i not in read]
            if not ids:
                ask.error = "no servo is handled"
        except Exception as exc:  # the loop goes on whatever a save meets
            ask.error = f"{type(exc).__name__}: {exc}"
        finally:
            ask.taken.set()


def attach(node) -> ServoSnapshot | None:
    """The service where std_srvs is installed (None, with one line, where it is not)."""
    try:
        import std_srvs.srv  # noqa: F401
    except ImportError as exc:
        node.get_logger().info(f"std_srvs is not available ({exc}): no dynamixel/save_servo_settings service")
        return None
    return ServoSnapshot(node)


__all__ = ["DEFAULT_NAME", "ServoSnapshot", "attach", "refusal", "write_atomically"]
