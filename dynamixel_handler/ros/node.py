"""The dynamixel_handler node: parameters, start-up on the bus, and the wiring of the loop.

The bus loop is ``runner.Runner`` (ROS-free) on its own thread at ``loop_rate``; the node hands it
the command topics (``intake.py``: taken by the loop thread itself), and gets each loop's states
back for the publishing thread (``outbox.py``, ``publishers.py``) and the step hooks (joint
states, diagnostics, the trajectory follower). The executor threads run services, actions and
parameter callbacks, which queue work for the loop (they never touch the bus). ``stamp`` is the time
the loop's reads went out, on the node's clock (simulated time with ``use_sim_time``), as every
other stamp the node publishes. The process around it (signals, exit codes) is ``process.py``.
"""
from __future__ import annotations

import logging
import os
import sys
import time
from typing import Any, Callable, cast

from rclpy.clock import ROSClock
from rclpy.node import Node

from dynamixel_handler_msgs.msg import DxlExternalPort

from .. import serial_ports
from ..bus import BusError, DynamixelBus
from ..bus.owner_record import remove_record, write_record
from ..commands import Commander
from ..core.handler import Handler, StepReport
from ..dummy import BusWithDummies, make_dummies
from ..errors import StartupError
from ..external_ports import ExternalPorts, PortReading
from ..loop.runner import Hooks, Runner, log_exception
from ..tools.baudrate import search_rates, unify_baudrate
from . import calibration, diagnostics, e_stop, fastpath, item_services, joint_commands, joint_states, manifest, services, snapshot
from .command_topics import COMMAND_TYPES, CommandTopics
from .intake import CommandIntake
from .lean import lean_publisher, lean_subscription
from .outbox import Loop, Outbox
from .params import declare_and_load, describe
from .process import NODE_NAME, _logger_of, run
from .publishers import STATE_TYPES, Batch, StatePublishers

#: environment variable: number of loop steps that fail on purpose (tests, fault drills)
INJECT_ENV = "DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS"

__all__ = ["DynamixelHandlerNode", "INJECT_ENV", "NODE_NAME", "log_exception", "main", "run", "_logger_of"]


class _LoggerAdapter:
    """Lets ROS-free modules log through the node's rcutils logger (logging.Logger-like)."""

    def __init__(self, ros_logger, prefix: str = "") -> None:
        self._log = ros_logger
        self._prefix = prefix  # put before every line, e.g. "baudrate auto set: "

    def debug(self, msg: str, *a) -> None:
        self._log.debug(self._prefix + (msg % a if a else msg))

    def info(self, msg: str, *a) -> None:
        self._log.info(self._prefix + (msg % a if a else msg))

    def warning(self, msg: str, *a) -> None:
        self._log.warning(self._prefix + (msg % a if a else msg))

    warn = warning

    def error(self, msg: str, *a) -> None:
        self._log.error(self._prefix + (msg % a if a else msg))

    def log(self, level: int, msg: str, *a) -> None:
        (self.error if level >= 40 else self.warning if level >= 30 else self.info if level >= 20 else self.debug)(msg, *a)

    def isEnabledFor(self, level: int) -> bool:  # noqa: N802 (logging.Logger API)
        return True


class DynamixelHandlerNode(Node):
    def __init__(self, interrupted: Callable[[], bool] = lambda: False) -> None:
        """``interrupted``: true once the process is asked to exit (a scan or set-up in progress
        stops between two steps)."""
        super().__init__(NODE_NAME, automatically_declare_parameters_from_overrides=True)
        self.config = declare_and_load(self)  # by parameter name; typed: self.settings
        self.settings = cfg = self.config.settings
        log = self.get_logger()
        for line in describe(self.config):  # one log line each: every line carries the logger's name
            log.info("parameters: " + line.strip())
        self.adapter = _LoggerAdapter(log)
        device, chosen = self._device()  # serial:<USB serial number> -> the adapter
        if chosen is not None:
            log.info(chosen)
        self.wire = DynamixelBus.of(device, cfg.bus, logger=self.adapter)
        self._device_path = device
        #: the owner record beside the port lock while the device is open (``bus/owner_record.py``)
        self._owner_record: list[str] = []
        if cfg.scan.ignored_dummy_ids:
            log.warning(f"init/dummy_servo_list: IDs {list(cfg.scan.ignored_dummy_ids)} are outside 0..252: ignored")
        self.bus = BusWithDummies(self.wire, make_dummies(list(cfg.scan.dummy_ids), list(cfg.scan.dummy_series)))
        self.handler = Handler(self.bus, self.config, cast(logging.Logger, self.adapter),  # logging.Logger-like
                               interrupted=interrupted)
        self.runner: Runner | None = None  # the loop, while it runs
        #: the loop was asked to stop (or gave up) and was not started again
        self.loop_stopped = False
        self.failed = False
        # fault injection for tests and drills: the first N loop steps raise
        self._injected_faults = int(os.environ.get(INJECT_ENV, "0") or 0)
        self.on_failure: Callable[[], None] | None = None  # called from the loop thread when the loop gives up
        self.outbox: Outbox | None = None  # the publishing thread, while the loop runs
        self._create_publishers()
        self._create_subscriptions()
        #: the joints with their saved offsets (None without joints); calibrated on the loop thread
        self.joints = calibration.live_joints(self)
        # called on the loop thread after each step's state publishing (joint states, diagnostics)
        self.step_hooks: list[Callable[[StepReport], None]] = [
            h for h in (joint_states.attach(self), diagnostics.attach(self)) if h is not None]
        # joint_commands, joint_trajectory, follow_joint_trajectory: the trajectory follower is a hook too
        self.step_hooks += [h for h in (joint_commands.attach(self),) if h is not None]
        self._attach_trajectory_action()
        self.motion_services = services.attach(self)  # set_torque, move_to, move_joints
        self.item_services = item_services.attach(self, self.motion_services)  # get_items, set_items
        self.e_stop = e_stop.attach(self)  # dynamixel/e_stop, set_e_stop, e_stop_state
        self.step_hooks += [self.e_stop, manifest.attach(self)]  # dynamixel/manifest
        self.snapshot = snapshot.attach(self)  # save_servo_settings: the servos block as a file

    def _attach_trajectory_action(self) -> None:
        """``~/follow_joint_trajectory`` beside the joint topics, when control_msgs is installed.
        Our own action module is imported unguarded: an error in it stops the node with its
        traceback instead of reading as a missing control_msgs."""
        commands = getattr(self, "joint_commands", None)
        if commands is None:  # joint_state.use is off
            return
        missing = joint_commands.missing_package("control_msgs")
        if missing is not None:  # everything else works without it
            self.get_logger().info(f"control_msgs is not available ({missing}): no follow_joint_trajectory action "
                                   "(joint_commands and joint_trajectory work)")
            return
        from . import trajectory_action
        commands.action = trajectory_action.attach(self, commands)

    def _device(self) -> tuple[str, str | None]:
        try:
            return serial_ports.resolve(self.settings.bus.device)
        except StartupError as err:  # as for a missing device: debug and dummy-only runs go on
            if not (self.settings.loop.debug or self.settings.scan.dummy_ids):
                raise
            self.get_logger().warning(f"{err} (running without the device)")
            return self.settings.bus.device, None

    # ------------------------------------------------------------------ wiring
    def _create_publishers(self) -> None:
        # which of rclpy's public API the node goes beyond (fastpath.py); one INFO line says so
        self.fast = fastpath.choose(self, (*STATE_TYPES, *COMMAND_TYPES), self.get_logger())
        self.state_pubs = StatePublishers(self, self.fast.raw_publish, self.settings.ros.command_line,
                                          self.settings.ratios.outdated_present)

    def _create_subscriptions(self) -> None:
        self.commander = Commander(self.handler)
        self.handler.attach(self.commander)  # the command topics' requests, taken in the loop thread
        # command topics are taken by the loop thread at the start of each step (intake.py)
        self.intake = CommandIntake(self, self.fast.raw_intake, self.fast.detached_intake)
        self.command_topics = CommandTopics(self.intake, self.commander, self.settings.scan.used_series,
                                            command_line=self.settings.ros.command_line)
        self.external_ports: ExternalPorts | None = None
        if self.settings.external_port.use:
            self.external_ports = ExternalPorts(self.handler, self.settings.external_port)
            self.handler.attach(self.external_ports)
            self.pub_external = lean_publisher(self, DxlExternalPort, "dynamixel/external_port/read", 10)
            lean_subscription(self, DxlExternalPort, "dynamixel/external_port/write", self._on_external_write, 10)

    def _on_external_write(self, msg: DxlExternalPort) -> None:
        try:
            assert self.external_ports is not None
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
            if not (self.settings.loop.debug or self.bus.dummies):
                raise
            why = "debug" if self.settings.loop.debug else "dummy servos only"
            self.get_logger().warning(f"{err} ({why}: running without the device)")
        if self.wire.is_open:  # the set-up tool finds this node from the device (and goes through it)
            self._owner_record = write_record(self._device_path, self.get_fully_qualified_name(), self.get_namespace(),
                                              self.context.get_domain_id())
        if self.settings.scan.baudrate_auto_set and self.wire.is_open:
            self._unify_baudrate()
        self.handler.start()

    def start_loop(self) -> None:
        # until the first loops are measured, the bus watchdog time follows the wire time of a loop
        self.handler.watchdog.note_loop_period(self.handler.reads.wire_s_per_loop())
        if self.outbox is None:
            self.outbox = Outbox(self.get_logger(), self._loop_messages)
        hooks = Hooks(before_step=self._before_step, take_commands=self.intake.poll, wait_commands=self.intake.wait,
                      states_ready=self._end_step, external_read=self._publish_external, report=self._report,
                      gave_up=self._gave_up)
        self.loop_stopped = False
        self.runner = Runner(self.handler, self.wire, self.settings.loop.rate_hz, self.settings.loop.verbose_ratio,
                             self.get_logger(), hooks, self.external_ports)
        self.runner.start()
        self.get_logger().info(f"loop running: {len(self.handler.table)} servo(s) at "
                               f"{self.settings.loop.rate_hz} Hz")

    def _unify_baudrate(self) -> None:
        """init/baudrate_auto_set: move servos found at other rates to `baudrate` before the scan."""
        scan, baudrate = self.settings.scan, self.settings.bus.baudrate
        ids = range(scan.min_id, scan.max_id + 1)
        log = _LoggerAdapter(self.get_logger(), "baudrate auto set: ")  # every line of it says so
        report = unify_baudrate(self.wire, baudrate, ids, search_rates(9600, 10_500_000), log)
        for line in report.summary():
            (log.info if report.ok else log.warning)(line)
        if self.wire.baudrate != baudrate:
            self.wire.set_baudrate(baudrate)

    def stop_loop(self) -> None:
        """Stop the loop (nothing left on the wire) and the publishing thread."""
        self.loop_stopped = True
        if self.runner is not None:
            self.runner.stop()
            self.runner = None
        self._close_outbox()

    @property
    def loop_running(self) -> bool:
        return self.runner is not None and self.runner.running

    def stop(self) -> None:
        """Stop the loop, make the servos safe as term/* say, close the port."""
        self.stop_loop()
        try:
            if self.bus.is_open:
                self.handler.shutdown()
        finally:
            self.close_wire()

    def close_wire(self) -> None:
        """Close the device and remove the owner record."""
        self.wire.close()
        remove_record(self._owner_record)
        self._owner_record = []

    def _close_outbox(self) -> None:
        if self.outbox is not None:
            self.outbox.close()
            self.outbox = None

    def destroy_node(self) -> None:
        self.intake.close()  # its subscriptions are not in the node's list
        super().destroy_node()

    # ------------------------------------------------------------------ the loop's hooks (loop thread)
    def _end_step(self, report: StepReport) -> None:
        """A loop's reads are stored: hand its messages to the publishing thread, run the hooks."""
        self._publish(report)
        for hook in self.step_hooks:
            hook(report)

    def _before_step(self) -> None:
        if self._injected_faults > 0:  # fault drills: the first N loop steps fail
            self._injected_faults -= 1
            raise RuntimeError(f"fault injected by {INJECT_ENV}")

    def _report(self, kind: str, level: int, text: str) -> None:
        """The statistics line and the rate warning, at the level the runner gives."""
        log = self.get_logger()  # one call site per severity: rcutils keeps a call site's severity
        if level >= logging.ERROR:
            log.error(text)
        elif level >= logging.WARNING:
            log.warning(text)
        else:
            log.info(text)

    def _gave_up(self) -> None:
        self.failed = self.loop_stopped = True
        if self.on_failure is not None:
            self.on_failure()

    def _publish_external(self, reading: PortReading) -> None:
        msg = DxlExternalPort(id_list=reading.ids, port=reading.ports, mode=reading.modes, data=reading.data)
        msg.stamp = self.get_clock().now().to_msg()
        self.pub_external.publish(msg)

    def _publish(self, report: StepReport) -> None:
        """Hand this loop's messages to the publishing thread (``outbox.py``)."""
        if (report.groups or report.present) and self.outbox is not None:
            snapshot = self.handler.table.snapshot()
            stamp = self._states_stamp(report.stamp)
            self.outbox.put(Loop(report, snapshot, stamp))

    def ros_time(self, wall: float) -> float:
        """A wall-clock time (``time.time()``, as the loop stamps its reads) on the node's clock, so
        that with ``use_sim_time`` every stamp follows /clock: the clock's now, less the wall time
        since. 0 while a simulated clock has not started."""
        now = self.get_clock().now().nanoseconds * 1e-9
        return max(0.0, now - max(0.0, time.time() - wall))

    def _states_stamp(self, wall: float) -> float:
        """``ros_time(wall)``; without a simulated clock, the node's clock is the wall clock."""
        clock = self.get_clock()
        if isinstance(clock, ROSClock) and not clock.ros_time_is_active:
            return max(0.0, wall)
        return self.ros_time(wall)

    def _loop_messages(self, loop: Loop) -> Batch:
        """A loop's messages, on the publishing thread."""
        return self.state_pubs.messages(loop.report, loop.table, loop.stamp)

    def _messages(self, report: StepReport, table: Any = None, stamp: float | None = None) -> Batch:
        """What this loop read, per topic (``publishers.py``); by default the table as it is now."""
        table = self.handler.table if table is None else table
        stamp = self._states_stamp(report.stamp) if stamp is None else stamp
        return self.state_pubs.messages(report, table, stamp)


def main(args: list[str] | None = None) -> int:
    return run(DynamixelHandlerNode, lambda node: node.start(), args)


if __name__ == "__main__":
    sys.exit(main())
