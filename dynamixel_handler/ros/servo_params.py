"""The ``servos`` block's parameters declared with their type and meaning (``ros2 param describe``).

ROS declares them from the overrides (the node is created with
``automatically_declare_parameters_from_overrides``), without a description; once the block is
read (``servo_settings.servo_block``), each is declared again, read-only, typed as its item and
described: servo, item, unit and the message field it is named after.
"""
from __future__ import annotations

from typing import Any, Mapping

from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.node import Node

from ..servo.settings import FIELDS, PREFIX, ServoSetting

_TYPES = {bool: ParameterType.PARAMETER_BOOL, int: ParameterType.PARAMETER_INTEGER,
          float: ParameterType.PARAMETER_DOUBLE, str: ParameterType.PARAMETER_STRING}


def declare_servo_block(node: Node, given: Mapping[str, Any], entries: tuple[ServoSetting, ...]) -> None:
    """Each ``servos.<name>.<item>`` of ``given`` declared again with its descriptor and the value
    the entry holds (in the item's type)."""
    by_name = {e.name: e for e in entries}
    for name in given:
        servo, _, item = name[len(PREFIX):].partition(".")
        entry = by_name.get(servo)
        if entry is None or item not in entry.values:
            continue
        spec, value = FIELDS[item], entry.values[item]
        description = f"servos block: {spec.meaning} of servo {entry.name} (ID {entry.dxl_id}), set at start-up and kept"
        if node.has_parameter(name):
            node.undeclare_parameter(name)
        node.declare_parameter(name, value, ParameterDescriptor(name=name, type=_TYPES[spec.type], description=description,
                                                                read_only=True), ignore_override=True)


__all__ = ["declare_servo_block"]
