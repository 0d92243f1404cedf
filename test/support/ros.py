"""Helpers for tests that run the real node and talk to it through real rclpy topics."""
from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "config" / "config_dynamixel_handler.yaml"
#: start-up scans of a test node (init/servo_auto_search.retry_times), 100 ms apart: on a host overloaded
#: fourfold six scans in a row have missed the virtual bus's reply to a 1 ms adapter's wait; the
#: retries cost nothing once every servo answers
SCAN_RETRIES = 20
PATIENT_SCAN = f"init/servo_auto_search.retry_times:={SCAN_RETRIES}"


def node_command(*ros_args: str, params_file: Path | None = CONFIG) -> list[str]:
    """The installed console script (as `ros2 run` would start it), with --ros-args."""
    cmd = [sys.executable, "-m", "dynamixel_handler.ros.node"] if os.environ.get("DXL_TEST_MODULE") else ["dynamixel_handler"]
    args = ["--ros-args"]
    if params_file is not None:
        args += ["--params-file", str(params_file)]
    for a in ros_args:
        args += ["-p", a]
    return cmd + args


def _die_with_parent() -> None:
    """In the child: get SIGTERM when the test process dies, so no node outlives a crashed test."""
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


class NodeProcess:
    """A node started in its own process; output collected line by line."""

    def __init__(self, cmd: list[str], env: dict[str, str] | None = None) -> None:
        full_env = dict(os.environ)
        full_env.update(env or {})
        full_env["PYTHONUNBUFFERED"] = "1"
        full_env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=full_env,
                                     preexec_fn=_die_with_parent)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_for(self, predicate: Callable[[str], bool] | str, timeout: float = 20.0) -> str:
        """Wait until a line matches (substring or predicate); fail with the output so far."""
        test = (lambda s: predicate in s) if isinstance(predicate, str) else predicate
        end = time.monotonic() + timeout
        seen = 0
        while time.monotonic() < end:
            for line in self.lines[seen:]:
                if test(line):
                    return line
            seen = max(seen, len(self.lines) - 1) if self.lines else 0
            if self.proc.poll() is not None and seen >= len(self.lines) - 1:
                time.sleep(0.1)
                for line in self.lines:
                    if test(line):
                        return line
                raise AssertionError(f"node exited ({self.proc.returncode}) before {predicate!r}:\n{self.output}")
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {predicate!r}:\n{self.output}")

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError(f"node did not stop within {timeout}s after signal {sig}:\n{self.output}")
        self._reader.join(2)
        return self.proc.returncode

    def wait_exit(self, timeout: float = 20.0) -> int:
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            raise AssertionError(f"node still running after {timeout}s:\n{self.output}")
        self._reader.join(2)
        return self.proc.returncode


def spin_until(node, executor, predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
        if predicate():
            return True
    return predicate()


class TopicClient:
    """An rclpy test node spun on a thread of its own: publish once the handler listens, wait for
    conditions with the node's log in the failure message. Subclasses set ``node`` and
    ``executor`` and provide ``output`` (the handler's log), then call ``_start_spinning()``."""

    node: object
    executor: object

    @property
    def output(self) -> str:
        return ""

    def _start_spinning(self) -> None:
        self._pubs: dict[tuple, object] = {}
        self._acked: dict[tuple, object] = {}  # (topic, type) -> the node process that acknowledged it
        self._lock = threading.Lock()
        self._spinning = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _stop_spinning(self) -> None:
        self._spinning = False
        self._thread.join(2)

    def _spin(self) -> None:
        while self._spinning:
            with self._lock:
                self.executor.spin_once(timeout_sec=0.02)

    def locked(self, fn: Callable, *args, **kwargs):
        """``fn(*args, **kwargs)`` with the spinning thread held off. For an action client's
        ``send_goal_async``, ``get_result_async`` and ``cancel_goal_async``: rclpy's ActionClient
        registers the request's future only after sending it, and drops an answer that the spinning
        thread takes before that (ros2/rclpy#1123), so the future would never complete."""
        with self._lock:
            return fn(*args, **kwargs)

    def call(self, srv_type, name: str, request, timeout: float = 30.0):
        """A service call from the listening node, answered within ``timeout``: its response."""
        with self._lock:
            client = self.node.create_client(srv_type, name)
        assert client.wait_for_service(timeout_sec=10), f"no service {name}"
        future = client.call_async(request)
        self.wait(future.done, timeout=timeout, what=f"the answer of {name}")
        return future.result()

    def publish(self, topic: str, msg) -> None:
        """Publish once the handler's subscription is matched (so the message is not lost). The
        first message of a publisher to a node (a new publisher, or the node started again) is
        waited for until the node has acknowledged it: the node matches the publisher on its own
        side, maybe after the publisher matched it, and a message sent before that came late or not
        at all (after a later one on another topic)."""
        key = (topic, type(msg))
        if key not in self._pubs:
            with self._lock:
                self._pubs[key] = self.node.create_publisher(type(msg), topic, 10)
        publisher = self._pubs[key]
        node = getattr(self, "node_proc", None)
        first = key not in self._acked or self._acked[key] is not node
        if first:
            self.wait(lambda: publisher.get_subscription_count() > 0, timeout=10, what=f"a subscriber of {topic}")
        publisher.publish(msg)
        if first:  # polled: a blocking wait in rmw may keep the interpreter lock from the virtual bus
            from rclpy.duration import Duration
            self.wait(lambda: publisher.wait_for_all_acked(Duration(nanoseconds=0)), timeout=5,
                      what=f"the first message on {topic} acknowledged")
            self._acked[key] = node

    def wait(self, predicate: Callable[[], object], timeout: float = 10.0, what: str = "condition") -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return
            time.sleep(0.02)
        raise AssertionError(f"timed out waiting for {what}\nnode output:\n{self.output[-4000:]}")
