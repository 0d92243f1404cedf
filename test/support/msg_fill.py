"""Fill every field of a generated message with distinct, deterministic values (and publish it).

Run as a script (`python msg_fill.py DxlStates /topic`) it publishes that message until killed, so
a test in another process can check that every field arrives unchanged.
"""
from __future__ import annotations

import importlib
import os
import sys

_SEQ = {
    "uint16": [1, 2, 65535], "int16": [-1, 4095, -32768], "double": [1.5, -2.25, 1e9],
    "boolean": [True, False, True], "string": ["position", "", "ex_position"],
}
_SCALAR = {"uint16": 7, "int16": -7, "double": 0.125, "boolean": True, "string": "torque_on",
           "int32": -123, "uint32": 456}


def nested_codecs(codec) -> list:
    """A ``cdr.Codec`` and the codecs of every sub-message in it, each once."""
    seen = {id(codec): codec}
    for _, kind, detail in codec.fields:
        if kind == "message":
            for inner in nested_codecs(detail):
                seen[id(inner)] = inner
    return list(seen.values())


def message_class(name: str):
    pkg, _, typ = name.rpartition("/") if "/" in name else ("dynamixel_handler_msgs/msg", "", name)
    module = importlib.import_module(pkg.replace("/", ".") if "." not in pkg else pkg)
    return getattr(module, typ)


def filled(cls, salt: int = 0):
    msg = cls()
    for i, (field, typ) in enumerate(msg.get_fields_and_field_types().items()):
        if typ.startswith("sequence<"):
            inner = typ[len("sequence<"):-1]
            values = list(_SEQ[inner])
            if inner in ("uint16", "int16"):
                values = [(v + salt + i) if abs(v) < 30000 else v for v in values]
            setattr(msg, field, values)
        elif typ in _SCALAR:
            setattr(msg, field, _SCALAR[typ])
        else:  # nested message, e.g. builtin_interfaces/Time or dynamixel_handler_msgs/DynamixelStatus
            pkg, typ_name = typ.split("/")
            nested = message_class(f"{pkg}/msg/{typ_name}")
            setattr(msg, field, filled(nested, salt + i + 1))
    return msg


def main() -> None:
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    import rclpy
    from rclpy.node import Node

    type_name, topic = sys.argv[1], sys.argv[2]
    cls = message_class(type_name)
    rclpy.init()
    node = Node("msg_fill_publisher")
    pub = node.create_publisher(cls, topic, 10)
    msg = filled(cls)
    node.create_timer(0.05, lambda: pub.publish(msg))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, Exception):
        pass


if __name__ == "__main__":
    main()
