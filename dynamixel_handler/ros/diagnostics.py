"""``/diagnostics`` (diagnostic_msgs/DiagnosticArray): one status per servo, one for the bus, and one per
joint (``joints.health``, in the joint's units) where joints are configured.

Published from the loop thread every ``diagnostics.period_sec`` (1 s by default), from the
servo table as last read, so it costs no bus traffic. Levels and messages come from
:mod:`dynamixel_handler.servo.health`; the topic is the absolute ``/diagnostics`` that
diagnostic_aggregator and rqt_robot_monitor read, and status names start with the node's full
name, so several handlers (one per bus) stay apart.
"""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from ..core.handler import StepReport
from ..joints.health import joint_health
from ..servo.health import BusSample, Health, bus_health, servo_health, silent_count
from .lean import lean_publisher


class DiagnosticsPublisher:
    """Loop hook: a DiagnosticArray once a period."""

    def __init__(self, node, period_s: float) -> None:
        self.node = node
        self.period_s = period_s
        self.pub = lean_publisher(node, DiagnosticArray, "/diagnostics", 10)
        self.prefix = node.get_fully_qualified_name().lstrip("/")
        self._since: float | None = None

    def _mark(self) -> None:
        f = self.node.handler.figures()
        self._since = time.monotonic()
        self._loops = f.loop_count
        self._stats = self.node.wire.stats.copy()
        self._reconnects = f.reconnects
        self._trips = f.watchdog_trips

    def __call__(self, report: StepReport) -> None:
        if self._since is None:
            self._mark()
            return
        now = time.monotonic()
        if now - self._since < self.period_s:
            return
        f, table = self.node.handler.figures(), self.node.handler.table
        delta = self.node.wire.stats.delta(self._stats)
        sample = BusSample(
            device=self.node.wire.device, elapsed_s=now - self._since, loops=f.loop_count - self._loops,
            target_rate_hz=float(self.node.settings.loop.rate_hz), transactions=delta.transactions,
            success_rate=delta.success_rate, device_lost=f.device_lost, reconnects_total=f.reconnects,
            reconnects_new=f.reconnects - self._reconnects, watchdog_trips_total=f.watchdog_trips,
            watchdog_trips_new=f.watchdog_trips - self._trips, servos=len(table), servos_silent=silent_count(table),
            e_stop=f.e_stop)
        statuses = [bus_health(sample, self.prefix)] + [servo_health(table, i, self.prefix) for i in table.ids]
        joints = getattr(self.node, "joints", None)
        if joints is not None and self.node.settings.ros.joint_state_use:
            statuses += joint_health(joints.map, table, self.prefix)  # in the joints' units
        msg = DiagnosticArray()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.status = [_to_msg(s) for s in statuses]
        self.pub.publish(msg)
        self._mark()


def _to_msg(health: Health) -> DiagnosticStatus:
    return DiagnosticStatus(level=bytes([health.level]), name=health.name, message=health.message,
                            hardware_id=health.hardware_id,
                            values=[KeyValue(key=k, value=v) for k, v in health.values])


def attach(node) -> DiagnosticsPublisher | None:
    period = node.settings.ros.diagnostics_period_s
    return DiagnosticsPublisher(node, period) if period > 0 else None
