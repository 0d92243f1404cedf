"""The node's process: rclpy start-up, signals, the executor thread, the safe stop and exit codes.

Exit codes: 0 normal stop, 1 start-up failure or a loop that kept failing, 2 bad parameter.
Shared by the plain node and the lifecycle node.
"""
from __future__ import annotations

import signal
import sys
import threading
import traceback
from typing import Any, Callable

import rclpy
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node

from ..bus import BusError
from ..errors import ConfigError, Interrupted, StartupError
from ..logs import Throttle, cut
from ..loop.runner import log_exception
from ..signal_flag import SignalFlag
from . import fastpath
from .params import check_arguments

NODE_NAME = "dynamixel_handler"
#: longest time (s) a thread that wants the interpreter lock waits for a busy one to give it up
SWITCH_INTERVAL_S = 0.0002
#: executor threads (subscriptions share one mutually exclusive group; services may wait)
EXECUTOR_THREADS = 6
#: longest "bad parameter" line [characters] (each value in it is cut shorter where it is made)
FATAL_LINE_MAX = 500


def _logger_of(exc: BaseException, fallback: Any) -> Any:
    """The logger of the node whose constructor raised ``exc`` (its frame is in the traceback),
    so that a start-up error carries the node's namespaced name; ``fallback`` if there is none."""
    tb = exc.__traceback__
    while tb is not None:
        obj = tb.tb_frame.f_locals.get("self")
        if isinstance(obj, Node):
            try:
                return obj.get_logger()
            except Exception:  # the node was not created far enough to have one
                break
        tb = tb.tb_next
    return fallback


class _Spinner:
    """The executor spun on its own thread until ``stopping``. An exception from a callback (a
    defect in one door) is one ERROR line a second per cause, its traceback at DEBUG, and the node
    goes on: the loop, the servos and every other door keep working. What ends the spinning
    (rclpy shut down from outside) is raised again on the main thread by ``join``."""

    def __init__(self, executor: MultiThreadedExecutor, stopping: threading.Event, wake: Callable[[], None],
                 log: Any = None) -> None:
        self.executor, self.stopping, self.wake = executor, stopping, wake
        self.error: BaseException | None = None
        self.log = log
        self._said = Throttle(lambda _msg: None)  # which causes were said this second
        self.thread = threading.Thread(target=self._spin, name="executor", daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            while not self.stopping.is_set() and self.executor.context.ok():
                try:
                    self.executor.spin_once(timeout_sec=0.5)
                except ExternalShutdownException:
                    raise
                except Exception as exc:
                    if self.log is None:
                        raise
                    if self.stopping.is_set() or not self.executor.context.ok():
                        break  # ending anyway
                    self._survived(exc)
        except BaseException as exc:
            self.error = exc
        finally:
            self.stopping.set()

    def _survived(self, exc: Exception) -> None:
        frames = traceback.extract_tb(exc.__traceback__)
        where = f"{frames[-1].filename}:{frames[-1].lineno}" if frames else ""
        if self._said("", key=f"{type(exc).__name__} {where}"):
            log_exception(self.log, "a callback failed (the node goes on)", exc)

    def join(self) -> None:
        self.wake()
        self.thread.join(2.0)
        error, self.error = self.error, None
        if error is not None:
            raise error


def _init_rclpy(args: list[str] | None, log: Any, came: SignalFlag) -> int | None:
    """rclpy.init, with bad arguments as one line; an exit code if it cannot start. SIGINT or
    SIGTERM while the arguments and params files are read ends it (exit 0, one line) as soon as
    rcl's parser returns (within a second or two: the files' limits see to that). The signals only
    set a flag meanwhile: a KeyboardInterrupt raised inside rclpy's C code could be lost there (the
    node then went on starting, the Ctrl-C ignored)."""
    came.install(signal.SIGINT, signal.SIGTERM)
    try:
        problem = check_arguments(sys.argv if args is None else args)
        if problem is not None:  # one line naming the file and the line, before rcl says less
            log.fatal(f"bad ROS arguments: {problem}")
            return 2
        if not came.came:
            rclpy.init(args=args, signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    except fastpath.RCLError as err:  # e.g. "-p name:=" with no value: one line, not a traceback
        log.fatal(f"bad ROS arguments: {str(err).split(', at ')[0]}")
        return 2
    if came.came:
        log.info("interrupted while reading the parameters: exiting")
        rclpy.try_shutdown()
        return 0
    return None


def _exit_code(exc: BaseException, log: Any) -> int:
    """One line for what ended the node before it ran; the exit code."""
    if isinstance(exc, ConfigError):
        log.fatal(f"bad parameter: {cut(exc, FATAL_LINE_MAX)}")  # values in it are the user's: never a huge line
        return 2
    if isinstance(exc, Interrupted):  # a signal during start-up: a normal exit
        log.info(f"{exc}: exiting")
        return 0
    if isinstance(exc, (BusError, StartupError)):
        log.fatal(str(exc))
        return 1
    if isinstance(exc, (KeyboardInterrupt, ExternalShutdownException)):
        return 0
    log_exception(log, "start-up failed", exc, fatal=True)  # one fatal line, the traceback at debug level
    return 1


class _Process:
    """One run of a handler node: a signal only sets ``signalled`` (a handler that takes no lock:
    see ``signal_flag``); the main thread then sets ``stopping``, which the other threads look at."""

    def __init__(self, signalled: SignalFlag) -> None:
        self.signalled = signalled
        self.stopping = threading.Event()
        self.waker: list[Any] = []  # a guard condition of the node: triggering it ends the executor's wait
        self.node: Any = None
        self.spinner: _Spinner | None = None
        # several threads: a waiting move service or action must not stall topics and cancels
        # (callbacks still only queue work for the loop thread)
        self.executor = MultiThreadedExecutor(num_threads=EXECUTOR_THREADS)

    def asked_to_stop(self) -> bool:
        """A signal came or the stop began: the node's start-up (scan, set-up) ends between two steps."""
        return self.signalled.came or self.stopping.is_set()

    def on_signal(self, *_: object) -> None:
        """Stop (never from a signal handler: this takes locks)."""
        self.stopping.set()
        for guard in self.waker:
            guard.trigger()

    def serve(self, node: Any, ready: Callable[[Any], None]) -> int:
        """Spin until a signal (or a loop that gave up); the exit code."""
        log = node.get_logger()
        node.on_failure = self.on_signal
        self.waker.append(node.create_guard_condition(lambda: None))
        ready(node)
        self.executor.add_node(node)
        # the executor spins on a thread of its own, so that the main thread sees a signal at once
        # (a signal handler only runs on the main thread, between two Python steps)
        self.spinner = _Spinner(self.executor, self.stopping, self.on_signal, log)
        self.signalled.wait(lambda: self.stopping.is_set() or not rclpy.ok())
        self.on_signal()  # here, on the main thread outside any lock, whatever ended the wait
        self.spinner.join()
        safety = [k for k in ("term/servo_auto_stop", "term/torque_auto_disable") if node.config[k]]
        if node.wire.is_open:
            log.info("stopping" + (f" ({', '.join(safety)})" if safety else ""))
        else:  # e.g. a lifecycle node never configured
            log.info("exiting: no device open, nothing to stop")
        return 1 if node.failed else 0

    def close(self, log: Any) -> None:
        self.stopping.set()
        if self.spinner is not None:
            self.spinner.join()
        if self.node is not None:
            try:
                self.node.stop()
            except Exception as exc:
                log.error(f"shutdown: {type(exc).__name__}: {exc}")
            self.node.destroy_node()
        self.executor.shutdown(timeout_sec=1.0)
        if rclpy.ok():
            rclpy.try_shutdown()


def run(make_node: Callable[[Callable[[], bool]], Any], ready: Callable[[Any], None], args: list[str] | None = None) -> int:
    """Run a handler node until SIGINT/SIGTERM (or a loop that gave up), then make the servos safe."""
    # the ROS environment (discovery range, domain, RMW) is the user's: the node changes none of it
    # the loop thread must get the interpreter lock back soon after the bus answers, even while
    # the publishing thread encodes (Python's default lets a waiting thread wait 5 ms)
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    log = rclpy.logging.get_logger(NODE_NAME)  # until the node (and so its namespace) exists
    came = SignalFlag()  # SIGINT/SIGTERM from here to the exit: the main thread looks at it
    code = _init_rclpy(args, log, came)
    if code is not None:
        return code
    proc = _Process(came)
    try:
        try:
            proc.node = make_node(proc.asked_to_stop)  # a signal during the scan or set-up ends it
        except Exception as exc:
            log = _logger_of(exc, log)  # the node's own (namespaced) logger if it got that far
            raise
        log = proc.node.get_logger()
        code = proc.serve(proc.node, ready)
    except (Exception, KeyboardInterrupt) as exc:
        code = _exit_code(exc, log)
    finally:
        proc.close(log)
    return code
