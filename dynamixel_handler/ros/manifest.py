"""``dynamixel/manifest``: what each servo is and how it is set, latched for tools that start late.

A ``diagnostic_msgs/DiagnosticArray`` (transient local, depth 1), one status per servo: model and
number, firmware, protocol, the bus's baud rate, operating mode, drive mode, the limits, homing
offset, gains and profiles in their units, and the joint name. A step hook looks at the values
the loop has read at most once a second and publishes again when one of them changed: after
start-up, a reboot, a reconnect, a mode change or a settings change (a new servo or one removed
too), never more than once a second."""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .. import units
from ..servo.groups import GAIN, LIMIT, MODE_NAMES

#: latched: the last manifest is kept for subscribers that come later
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: least time between two looks at the values (and so between two manifests) [s]
LOOK_S = 1.0
#: items shown in their units, then raw
IN_UNITS = (*LIMIT, "homing_offset", "profile_velocity", "profile_acceleration")
RAW = ("firmware_version", "operating_mode", "drive_mode", *GAIN)


class Manifest:
    """Step hook: the manifest published when what the loop read of the servos changed."""

    def __init__(self, node) -> None:
        self.node = node
        self.pub = node.create_publisher(DiagnosticArray, "dynamixel/manifest", QOS)
        self.prefix = node.get_fully_qualified_name().lstrip("/")
        joints = node.settings.ros.joints  # the servos of each joint: no calibration changes them
        self.joint_of = {i: j.name for j in joints.joints for i in j.servo_ids} if joints is not None else {}
        self._last: tuple | None = None
        self._looked = 0.0

    def __call__(self, _report: object = None) -> None:
        now = time.monotonic()
        if now - self._looked < LOOK_S:
            return
        self._looked = now
        key = self._key()
        if key != self._last:
            self._last = key
            self.pub.publish(self._message())

    def _key(self) -> tuple:
        table = self.node.handler.table
        return tuple((i, table.model(i).number, *(table.value(item, i) for item in (*RAW, *IN_UNITS)))
                     for i in table.ids)

    def _message(self) -> DiagnosticArray:
        msg = DiagnosticArray()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        table = self.node.handler.table
        msg.status = [self._servo(table, i) for i in table.ids]
        return msg

    def _servo(self, table, dxl_id: int) -> DiagnosticStatus:
        """One servo's status: what it is, then its values (raw, then in units)."""
        model = table.model(dxl_id)
        values = [("model", model.name), ("model_number", str(model.number)), ("protocol", f"{model.protocol}.0"),
                  ("baudrate", str(self.node.settings.bus.baudrate)), ("joint", self.joint_of.get(dxl_id, ""))]
        for item in RAW:
            raw = table.value(item, dxl_id) if model.has(item) else None
            if raw is None:
                continue
            shown = MODE_NAMES.get(raw, str(raw)) if item == "operating_mode" else str(raw)
            values.append((item, shown))
        for item in IN_UNITS:
            raw = table.value(item, dxl_id) if model.has(item) else None
            if raw is not None:
                values.append((f"{item} [{units.UNIT_OF_QUANTITY[units.quantity_of(item)]}]",
                               f"{float(units.pulse_to_unit([model], item, [raw])[0]):.6g}"))
        return DiagnosticStatus(level=DiagnosticStatus.OK, name=f"{self.prefix}: ID {dxl_id}", message=model.name,
                                hardware_id=f"ID {dxl_id}", values=[KeyValue(key=k, value=v) for k, v in values])


def attach(node) -> Manifest:
    return Manifest(node)
