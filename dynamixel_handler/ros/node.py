"""The dynamixel_handler node: parameters, start-up on the bus, the loop thread, publishing.

The bus loop runs on its own thread at ``loop_rate`` and takes the command topics itself
(``intake.py``); the executor threads run services, actions and parameter callbacks, which queue
work for the loop (they never touch the bus). Each loop's messages are built and published on the
publishing thread (``outbox.py``); ``stamp`` is the time the loop's reads went out, on the node's
clock (simulated time with ``use_sim_time``), as every other stamp the node publishes.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
import traceback
from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node

from dynamixel_handler_msgs.msg import (
    DxlExternalPort,
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

from .. import serial_ports
from ..bus import BusError, DynamixelBus
from ..commands import Commander
from ..dummy import BusWithDummies, make_dummies
from ..external_ports import ExternalPorts
from ..loop import Handler, Interrupted, StartupError, StepReport
from ..timing import set_timer_slack
from ..tools.baudrate import search_rates, unify_baudrate
from . import convert, diagnostics, joint_commands, joint_states, services
from .command_topics import COMMAND_TYPES, CommandTopics
from .intake import CommandIntake
from .lean import TreePublisher, lean_publisher, lean_subscription, raw_cdr_usable
from .loop_stats import LoopStats
from .outbox import Outbox
from .params import ConfigError, check_arguments, declare_and_load, describe

NODE_NAME = "dynamixel_handler"
#: consecutive failed loop steps after which the node stops the servos and exits
MAX_LOOP_FAILURES = 50
#: environment variable: number of loop steps that fail on purpose (tests, fault drills)
INJECT_ENV = "DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS"
#: messages the handler encodes/decodes itself; checked against the middleware at start-up
RAW_CHECKED = (DxlStates, DynamixelDebug, DynamixelStatus, DynamixelPresent, DynamixelGoal, DynamixelGain,
               DynamixelLimit, DynamixelError, DynamixelExtra, *COMMAND_TYPES)
#: longest time (s) a thread that wants the interpreter lock waits for a busy one to give it up
SWITCH_INTERVAL_S = 0.0002
#: running flat out, the next commands are taken this long (plus 1.5 x the time that takes) before
#: the replies of the read on the wire are due, at most MAX_EARLY_S before [s]
EARLY_MARGIN_S = 0.0002
MAX_EARLY_S = 0.002
#: between loops, a command is written at once unless the next loop starts within this time [s]
EARLY_WRITE_MIN_S = 0.0005
#: longest wait for a command before the loop looks at its stop flag again [s]
STOP_CHECK_S = 0.05
#: executor threads (subscriptions share one mutually exclusive group; services may wait)
EXECUTOR_THREADS = 6


def log_exception(log, what: str, exc: BaseException, fatal: bool = False) -> None:
    """One ERROR (or FATAL) line naming the exception and where it was raised; the traceback
    follows at DEBUG level, one log line per line, so every line carries severity and logger name."""
    frames = traceback.extract_tb(exc.__traceback__)
    where = f" (at {os.path.basename(frames[-1].filename)}:{frames[-1].lineno} in {frames[-1].name})" if frames else ""
    (log.fatal if fatal else log.error)(f"{what}: {type(exc).__name__}: {exc}{where}")
    for block in traceback.format_exception(type(exc), exc, exc.__traceback__, limit=6):
        for line in block.rstrip().splitlines():
            log.debug(f"{what}: {line}")


def _logger_of(exc: BaseException, fallback):
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


class _LoggerAdapter:
    """Lets ROS-free modules log through the node's rcutils logger (logging.Logger-like)."""

    def __init__(self, ros_logger) -> None:
        self._log = ros_logger

    def debug(self, msg: str, *a) -> None:
        self._log.debug(msg % a if a else msg)

    def info(self, msg: str, *a) -> None:
        self._log.info(msg % a if a else msg)

    def warning(self, msg: str, *a) -> None:
        self._log.warning(msg % a if a else msg)

    warn = warning

    def error(self, msg: str, *a) -> None:
        self._log.error(msg % a if a else msg)

    def log(self, level: int, msg: str, *a) -> None:
        (self.error if level >= 40 else self.warning if level >= 30 else self.info if level >= 20 else self.debug)(msg, *a)

    def isEnabledFor(self, level: int) -> bool:  # noqa: N802 (logging.Logger API)
        return True


class DynamixelHandlerNode(Node):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, automatically_declare_parameters_from_overrides=True)
        self.config = cfg = declare_and_load(self)
        log = self.get_logger()
        for line in describe(self.config):  # one log line each: every line carries the logger's name
            log.info("parameters: " + line.strip())
        self.adapter = _LoggerAdapter(log)
        device, chosen = self._device()  # serial:<USB serial number> -> the adapter
        if chosen is not None:
            log.info(chosen)
        self.wire = DynamixelBus(device, cfg["baudrate"], max(1.0, float(cfg["latency_timer"])),
                                 cfg["dyn_comm/retry_num"], float(cfg["dyn_comm/inerval_msec"]),
                                 verbose=cfg["dyn_comm/verbose"], logger=self.adapter)
        bad = [i for i in cfg["init/dummy_servo_list"] if i != -1 and not 0 <= i <= 252]
        if bad:
            log.warning(f"init/dummy_servo_list: IDs {bad} are outside 0..252: ignored")
        self.bus = BusWithDummies(self.wire, make_dummies(cfg.dummy_ids, cfg.dummy_series))
        self.handler = Handler(self.bus, cfg, self.adapter)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.failed = False
        # fault injection for tests and drills: the first N loop steps raise
        self._injected_faults = int(os.environ.get(INJECT_ENV, "0") or 0)
        self.on_failure = None  # called from the loop thread when the loop gives up
        self.outbox: Outbox | None = None  # the publishing thread, while the loop runs
        self._create_publishers()
        self._create_subscriptions()
        # called on the loop thread after each step's state publishing (joint states, diagnostics)
        self.step_hooks = [h for h in (joint_states.attach(self), diagnostics.attach(self)) if h is not None]
        # joint_commands, joint_trajectory, follow_joint_trajectory: the trajectory follower is a hook too
        self.step_hooks += [h for h in (joint_commands.attach(self),) if h is not None]
        self.motion_services = services.attach(self)  # set_torque, move_to, move_joints

    def _device(self) -> tuple[str, str | None]:
        try:
            return serial_ports.resolve(self.config["device_name"])
        except StartupError as err:  # as for a missing device: debug and dummy-only runs go on
            if not (self.config["debug"] or self.config.dummy_ids):
                raise
            self.get_logger().warning(f"{err} (running without the device)")
            return self.config["device_name"], None

    # ------------------------------------------------------------------ wiring
    def _create_publishers(self) -> None:
        # the handler writes and reads its own messages' CDR bytes when the middleware agrees (cdr.py)
        self.raw_cdr = raw_cdr_usable(RAW_CHECKED, self.get_logger())
        self.pub_states = TreePublisher(self, DxlStates, "dynamixel/states", 10, self.raw_cdr)
        self.pub_debug = TreePublisher(self, DynamixelDebug, "dynamixel/debug", 10, self.raw_cdr)
        self.pub_state: dict[str, TreePublisher] = {}
        if not self.config["no_use_command_line"]:
            for name, typ in (("status", DynamixelStatus), ("present", DynamixelPresent), ("goal", DynamixelGoal),
                              ("gain", DynamixelGain), ("limit", DynamixelLimit), ("error", DynamixelError),
                              ("extra", DynamixelExtra)):
                self.pub_state[name] = TreePublisher(self, typ, f"dynamixel/state/{name}", 10, self.raw_cdr)

    def _create_subscriptions(self) -> None:
        self.commander = Commander(self.handler)
        # command topics are taken by the loop thread at the start of each step (intake.py)
        self.intake = CommandIntake(self, self.raw_cdr)
        self.command_topics = CommandTopics(self.intake, self.commander, self.config.used_series,
                                            command_line=not self.config["no_use_command_line"])
        self.external_ports: ExternalPorts | None = None
        if self.config["option/external_port.use"]:
            self.external_ports = ExternalPorts(self.handler)
            self.pub_external = lean_publisher(self, DxlExternalPort, "dynamixel/external_port/read", 10)
            lean_subscription(self, DxlExternalPort, "dynamixel/external_port/write", self._on_external_write, 10)

    def _on_external_write(self, msg: DxlExternalPort) -> None:
        try:
            self.external_ports.write([int(i) for i in msg.id_list], [int(p) for p in msg.port], list(msg.mode),
                                      [int(d) for d in msg.data])
        except Exception as exc:  # a bad message must never take the node down
            self.get_logger().error(f"/dynamixel/external_port/write: dropped: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ start-up
    def start(self) -> None:
        """Open the bus and set up the servos; StartupError/BusError when that cannot be done."""
        self.open_and_scan()
        self.start_loop()

    def open_and_scan(self) -> None:
        """Open the device and scan/set up the servos (the lifecycle node's configure)."""
        try:
            self.wire.open()
        except BusError as err:
            if not (self.config["debug"] or self.bus.dummies):
                raise
            why = "debug" if self.config["debug"] else "dummy servos only"
            self.get_logger().warning(f"{err} ({why}: running without the device)")
        if self.config["init/baudrate_auto_set"] and self.wire.is_open:
            self._unify_baudrate()
        self.handler.start()

    def start_loop(self) -> None:
        # until the first loops are measured, the bus watchdog time follows the wire time of a loop
        self.handler.note_loop_period(self.handler.estimate_loop_s())
        self._stop.clear()
        if self.outbox is None:
            self.outbox = Outbox(self.get_logger())
        self._thread = threading.Thread(target=self._run, name="dynamixel_loop", daemon=True)
        self._thread.start()
        self.get_logger().info(f"loop running: {len(self.handler.table)} servo(s) at "
                               f"{self.config['loop_rate']} Hz")

    def _unify_baudrate(self) -> None:
        """init/baudrate_auto_set: move servos found at other rates to `baudrate` before the scan."""
        cfg = self.config
        ids = range(cfg["init/servo_auto_search.min_id"], cfg["init/servo_auto_search.max_id"] + 1)
        report = unify_baudrate(self.wire, cfg["baudrate"], ids, search_rates(9600, 10_500_000), self.adapter)
        for line in report.summary():
            (self.get_logger().info if report.ok else self.get_logger().warning)(f"baudrate auto set: {line}")
        if self.wire.baudrate != cfg["baudrate"]:
            self.wire.set_baudrate(cfg["baudrate"])

    def stop(self) -> None:
        """Stop the loop, make the servos safe as term/* say, close the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        self._close_outbox()
        try:
            if self.bus.is_open:
                self.handler.shutdown()
        finally:
            self.wire.close()

    def _close_outbox(self) -> None:
        if self.outbox is not None:
            self.outbox.close()
            self.outbox = None

    def destroy_node(self) -> None:
        self.intake.close()  # its subscriptions are not in the node's list
        super().destroy_node()

    # ------------------------------------------------------------------ the loop thread
    def _run(self) -> None:
        """The loop. Running flat out (a loop takes longer than a period), each loop's last read is
        left on the wire while the previous loop's states are stored and published and, shortly
        before its replies are due, the next commands are taken and checked; the goals go out as
        soon as the replies are in and the next reads right behind them, so the wire is busy while
        the previous loop is completed: the bus then waits on the wire, hardly on Python. With time to
        spare in a period, each loop ends before the sleep, so states go out as soon as they are
        read, and the sleep is cut short by the first command that arrives (``_sleep_until``)."""
        slack_ns = set_timer_slack()  # wake-ups on time, not up to 50 µs late (timing.py)
        if slack_ns is None:
            self.get_logger().debug("loop thread: timer slack left at the system default")
        period = 1.0 / self.config["loop_rate"]
        stats = LoopStats(self.handler, self.wire, self.get_logger(), self.config["loop_rate"],
                          self.config["verbose_ratio"])
        next_t = time.monotonic()
        failures = 0
        prev: StepReport | None = None  # a loop whose last read is still on the wire
        begin_s = 0.0                   # how long taking commands and beginning a step takes (average)
        while not self._stop.is_set():
            finished = None
            try:
                if self._injected_faults > 0:
                    self._injected_faults -= 1
                    raise RuntimeError(f"fault injected by {INJECT_ENV}")
                t0 = time.monotonic()
                self.intake.poll()
                report = self.handler.begin_step()
                if prev is not None:
                    self.handler.encode_writes()  # the goal packets ready before the line is free
                begin_s += 0.2 * (time.monotonic() - t0 - begin_s)
                if prev is not None:
                    self.handler.await_replies(prev)
                    if self.intake.poll():  # commands that came while the replies were due
                        self.handler.prepare(report)
                self.handler.send_writes(report)  # the goals first, the reads right behind them:
                reading = self.external_ports.step() if self.external_ports is not None else None
                self.handler.send_reads(report)   # the wire never waits for the bookkeeping below
                if prev is not None:
                    finished, prev = prev, None
                    self.handler.complete_step(finished)
                    self._end_step(finished)
                prev = report
                if reading is not None:
                    self._publish_external(reading)
                next_t += period
                # time to spare, or late by less than a period (made up by the loops after it): this
                # loop ends now; only a loop that keeps taking longer than a period runs flat out
                if next_t + period > time.monotonic() or self.handler.reply_eta is None:
                    finished, prev = prev, None
                    self._end_step(finished)
                failures = 0
            except Exception as exc:  # keep the loop alive; the context says where it broke
                failures += 1
                prev = None
                next_t += period
                log_exception(self.get_logger(), f"loop {self.handler.loop_count}", exc)
                if failures >= MAX_LOOP_FAILURES:
                    self.get_logger().fatal(f"the loop failed {failures} times in a row: shutting down safely")
                    self.failed = True
                    self._stop.set()
                    if self.on_failure is not None:
                        self.on_failure()
                    return
            stats.tick(finished)
            now = time.monotonic()
            if prev is None:
                if next_t > now:
                    self._sleep_until(next_t)
                else:
                    # overran: the next loop starts now; up to one period late is made up by the
                    # loops after it (so scheduling jitter under load does not lower the rate),
                    # more is not caught up
                    next_t = max(next_t, now - period)
            else:
                next_t = now
                eta = self.handler.reply_eta
                if eta is not None:  # take the next commands as late as the replies allow
                    wake = eta - min(MAX_EARLY_S, 1.5 * begin_s + EARLY_MARGIN_S)
                    if wake > now:
                        self._stop.wait(wake - now)
        if prev is not None:
            try:
                self.handler.complete_step(prev)  # nothing stays on the wire once the loop has stopped
            except Exception as exc:
                self.get_logger().warning(f"last read: {type(exc).__name__}: {exc}")

    def _sleep_until(self, t: float) -> None:
        """Sleep until the next loop. The first command that arrives meanwhile is applied at once
        (its sync write does not wait for the next loop); later ones in the same period wait for
        the loop, so commands add at most one write per period to the bus."""
        while not self._stop.is_set():
            remaining = t - time.monotonic()
            if remaining <= EARLY_WRITE_MIN_S:
                break
            if self.intake.wait(min(remaining, STOP_CHECK_S)) and self.intake.poll():
                try:
                    self.handler.apply_now()
                except Exception as exc:  # as in the loop: logged, never fatal
                    log_exception(self.get_logger(), "applying a command between loops", exc)
                break
        remaining = t - time.monotonic()
        if remaining > 0:
            self._stop.wait(remaining)

    def _end_step(self, report: StepReport) -> None:
        """Store and log what a loop read, hand its messages to the publishing thread, run the hooks."""
        self.handler.finish_step(report)
        self._publish(report)
        for hook in self.step_hooks:
            hook(report)

    def _publish_external(self, reading) -> None:
        if reading is None:
            return
        msg = DxlExternalPort(id_list=reading.ids, port=reading.ports, mode=reading.modes, data=reading.data)
        msg.stamp = self.get_clock().now().to_msg()
        self.pub_external.publish(msg)

    def _publish(self, report: StepReport) -> None:
        """Hand this loop's messages to the publishing thread (``outbox.py``)."""
        if report.groups or report.present:
            snapshot = self.handler.table.snapshot()
            stamp = self.ros_time(report.stamp)
            self.outbox.put(lambda: self._messages(report, snapshot, stamp))

    def ros_time(self, wall: float) -> float:
        """A wall-clock time (``time.time()``, as the loop stamps its reads) on the node's clock, so
        that with ``use_sim_time`` every stamp follows /clock: the clock's now, less the wall time
        since. 0 while a simulated clock has not started."""
        now = self.get_clock().now().nanoseconds * 1e-9
        return max(0.0, now - max(0.0, time.time() - wall))

    def _messages(self, report: StepReport, table=None, stamp: float | None = None) -> list[tuple[TreePublisher, dict]]:
        """What this loop read, per topic; a message nobody subscribes to is not even built.
        ``stamp``: the time of the reads on the node's clock (``ros_time``)."""
        table = self.handler.table if table is None else table
        stamp = self.ros_time(report.stamp) if stamp is None else stamp
        groups, present_keys = report.groups, report.present
        if not (groups or present_keys):
            return []
        out = []
        parts = convert.Parts(table, present_keys, self.config["pub_outdated_present_value"])
        if self.pub_states.wanted():
            out.append((self.pub_states, convert.states(table, stamp, groups, present_keys, parts=parts,
                                                        outdated_present=self.config["pub_outdated_present_value"])))
        if (present_keys or "status" in groups) and self.pub_debug.wanted():
            out.append((self.pub_debug, convert.debug(table, parts.get("status"))))
        if not self.pub_state:
            return out
        pubs = self.pub_state
        due = {name for name in ("status", "goal", "gain", "limit", "error") if name in groups}
        if present_keys:
            due.add("present")
        if groups & {"extra_dynamic", "extra_static"}:
            due.add("extra")
        for name in due:
            if pubs[name].wanted():
                out.append((pubs[name], parts.get(name)))
        return out


def run(make_node: Callable[[], Node], ready: Callable[[Node], None], args: list[str] | None = None) -> int:
    """Run a handler node until SIGINT/SIGTERM (or a loop that gave up), then make the servos safe.

    Exit codes: 0 normal stop, 1 start-up failure or a loop that kept failing, 2 bad parameter.
    Shared by the plain node and the lifecycle node.
    """
    # the ROS environment (discovery range, domain, RMW) is the user's: the node changes none of it
    # the loop thread must get the interpreter lock back soon after the bus answers, even while
    # the publishing thread encodes (Python's default lets a waiting thread wait 5 ms)
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    log = rclpy.logging.get_logger(NODE_NAME)  # until the node (and so its namespace) exists
    problem = check_arguments(sys.argv if args is None else args)
    if problem is not None:  # one line naming the file and the line, before rcl says less
        log.fatal(f"bad ROS arguments: {problem}")
        return 2
    try:
        rclpy.init(args=args, signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    except _rclpy.RCLError as err:  # e.g. "-p name:=" with no value: one line, not a traceback
        log.fatal(f"bad ROS arguments: {str(err).split(', at ')[0]}")
        return 2
    node = None
    # several threads: a waiting move service or action must not stall topics and cancels
    # (callbacks still only queue work for the loop thread)
    executor = MultiThreadedExecutor(num_threads=EXECUTOR_THREADS)
    stopping = threading.Event()
    waker = []  # a guard condition of the node: triggering it ends the executor's wait at once

    def on_signal(*_) -> None:
        stopping.set()
        for guard in waker:
            guard.trigger()
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    code = 0
    spinner: _Spinner | None = None
    try:
        try:
            node = make_node()
        except Exception as exc:
            log = _logger_of(exc, log)  # the node's own (namespaced) logger if it got that far
            raise
        log = node.get_logger()
        node.on_failure = on_signal
        node.handler.interrupted = stopping.is_set  # a signal during the scan or set-up ends it
        waker.append(node.create_guard_condition(lambda: None))
        ready(node)
        executor.add_node(node)
        # the executor spins on a thread of its own, so that the main thread sees a signal at once
        # (a signal handler only runs on the main thread, between two Python steps)
        spinner = _Spinner(executor, stopping, on_signal)
        while not stopping.wait(0.05) and rclpy.ok():
            pass
        spinner.join()
        safety = [k for k in ("term/servo_auto_stop", "term/torque_auto_disable") if node.config[k]]
        if node.wire.is_open:
            log.info("stopping" + (f" ({', '.join(safety)})" if safety else ""))
        else:  # e.g. a lifecycle node never configured
            log.info("exiting: no device open, nothing to stop")
        if node.failed:
            code = 1
    except ConfigError as err:
        log.fatal(f"bad parameter: {err}")
        code = 2
    except Interrupted as err:  # a signal during start-up: a normal exit
        log.info(f"{err}: exiting")
    except (BusError, StartupError) as err:
        log.fatal(str(err))
        code = 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:  # anything else at start-up: one fatal line, the traceback at debug level
        log_exception(log, "start-up failed", exc, fatal=True)
        code = 1
    finally:
        stopping.set()
        if spinner is not None:
            spinner.join()
        if node is not None:
            try:
                node.stop()
            except Exception as exc:
                log.error(f"shutdown: {type(exc).__name__}: {exc}")
            node.destroy_node()
        executor.shutdown(timeout_sec=1.0)
        if rclpy.ok():
            rclpy.try_shutdown()
    return code


class _Spinner:
    """The executor spun on its own thread until ``stopping``; an exception from a callback is
    raised again on the main thread by ``join`` (as if the main thread had spun)."""

    def __init__(self, executor, stopping: threading.Event, wake: Callable[[], None]) -> None:
        self.executor, self.stopping, self.wake = executor, stopping, wake
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._spin, name="executor", daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            while not self.stopping.is_set() and rclpy.ok():
                self.executor.spin_once(timeout_sec=0.5)
        except BaseException as exc:
            self.error = exc
        finally:
            self.stopping.set()

    def join(self) -> None:
        self.wake()
        self.thread.join(2.0)
        error, self.error = self.error, None
        if error is not None:
            raise error


def main(args: list[str] | None = None) -> int:
    return run(DynamixelHandlerNode, lambda node: node.start(), args)

if __name__ == "__main__":
    sys.exit(main())
