#!/usr/bin/env python3
"""Stand-ins for a few `ros2` commands where the ROS 2 command line is not installed.

The `ros2` command (ros2cli) and `launch` are not on PyPI, so a machine set up from the PyPI wheels
(scripts/setup.sh) has rclpy but no `ros2`. This script does what these commands do, with rclpy:

    python scripts/ros_cli.py topic echo /dynamixel/states [--once] [--field present.position_deg]
    python scripts/ros_cli.py topic hz /dynamixel/states [--seconds 5]
    python scripts/ros_cli.py topic pub /dynamixel/shortcut dynamixel_handler_msgs/msg/DynamixelShortcut \\
        "{command: 'TON', id_list: [1]}"
    python scripts/ros_cli.py param get /dynamixel_handler loop_rate
    python scripts/ros_cli.py launch launch_dynamixel_handler.py name_space:=robot1 device_name:=/dev/pts/3

`launch` reads the installed launch file as `ros2 launch` would (test/support/launch_runner.py) and runs the
node it describes in the foreground. Like the other scripts, it keeps DDS discovery on this machine
unless ROS_AUTOMATIC_DISCOVERY_RANGE is set.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import rclpy  # noqa: E402
import yaml  # noqa: E402
from rclpy.duration import Duration  # noqa: E402
from rclpy.node import Node  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def _type(name: str):
    package, _, cls = name.replace("/msg/", "/").partition("/")
    return getattr(importlib.import_module(f"{package}.msg"), cls)


def _to_dict(msg):
    if hasattr(msg, "get_fields_and_field_types"):
        return {f: _to_dict(getattr(msg, f)) for f in msg.get_fields_and_field_types()}
    if isinstance(msg, (list, tuple)) or hasattr(msg, "tolist"):
        return [_to_dict(v) for v in (msg.tolist() if hasattr(msg, "tolist") else msg)]
    return msg


def _fill(msg, values: dict):
    for name, value in values.items():
        current = getattr(msg, name)
        if isinstance(value, dict):
            _fill(current, value)
        else:
            setattr(msg, name, value)
    return msg


def _topic_type(node: Node, topic: str, timeout: float = 10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for name, types in node.get_topic_names_and_types():
            if name == topic:
                return _type(types[0])
        rclpy.spin_once(node, timeout_sec=0.1)
    sys.exit(f"topic {topic} not found")


def _pick(tree, field: str | None):
    for part in (field.split(".") if field else []):
        tree = tree[part]
    return tree


def topic_echo(args) -> None:
    node = Node("ros_cli_echo")
    got: list = []
    node.create_subscription(_topic_type(node, args.topic), args.topic, got.append, 10)
    while rclpy.ok():
        rclpy.spin_once(node, timeout_sec=0.1)
        while got:
            print(yaml.safe_dump(_pick(_to_dict(got.pop(0)), args.field), default_flow_style=None, sort_keys=False)
                  + "---", flush=True)
            if args.once:
                return


def topic_hz(args) -> None:
    node = Node("ros_cli_hz")
    stamps: list[float] = []
    node.create_subscription(_topic_type(node, args.topic), args.topic, lambda _: stamps.append(time.monotonic()), 50)
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    if len(stamps) < 2:
        sys.exit(f"fewer than 2 messages on {args.topic}")
    print(f"average rate: {(len(stamps) - 1) / (stamps[-1] - stamps[0]):.1f} Hz over {len(stamps)} messages")


#: seconds `topic pub` waits for its subscribers to acknowledge the message
ACK_TIMEOUT_S = 5.0


def topic_pub(args) -> None:
    node = Node("ros_cli_pub")
    typ = _type(args.type)
    pub = node.create_publisher(typ, args.topic, 10)
    end = time.monotonic() + 10
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    msg = _fill(typ(), yaml.safe_load(args.values) or {})
    print(f"publisher: beginning loop\npublishing #1: {msg}\n")
    pub.publish(msg)
    # A subscriber this publisher has matched may not yet have matched it back (DDS discovery runs on
    # each side on its own): its reader drops the first sample and asks for it again once it sees the
    # writer. Leaving before that loses the message, so wait until every matched reader has acknowledged it.
    if not pub.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S)):
        print(f"warning: not every subscriber of {args.topic} acknowledged the message within {ACK_TIMEOUT_S:.0f} s",
              file=sys.stderr)


def param_get(args) -> None:
    from rclpy.parameter import parameter_value_to_python
    from rclpy.parameter_client import AsyncParameterClient
    node = Node("ros_cli_param")
    client = AsyncParameterClient(node, args.node)
    if not client.wait_for_services(timeout_sec=10):
        sys.exit(f"node {args.node} not found")
    future = client.get_parameters([args.name])
    rclpy.spin_until_future_complete(node, future, timeout_sec=10)
    kinds = {1: "Boolean", 2: "Integer", 3: "Double", 4: "String", 6: "Boolean values are",
             7: "Integer values are", 8: "Double values are", 9: "String values are"}
    value = future.result().values[0]
    if value.type == 0:
        sys.exit("Parameter not set.")
    print(f"{kinds.get(value.type, 'Value')} value is: {parameter_value_to_python(value)}")


def launch(args) -> None:
    sys.path.insert(0, str(ROOT / "test"))
    from support.launch_runner import nodes
    arguments = dict(a.split(":=", 1) for a in args.arguments)
    found = nodes(args.file, **arguments)
    if len(found) != 1:
        sys.exit(f"{args.file} describes {len(found)} nodes; this stand-in runs one")
    cmd = found[0].command()
    print("[launch] " + " ".join(cmd), flush=True)
    os.execv(cmd[0], cmd)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="group", required=True)
    topic = sub.add_parser("topic").add_subparsers(dest="verb", required=True)
    p = topic.add_parser("echo")
    p.add_argument("topic")
    p.add_argument("--once", action="store_true")
    p.add_argument("--field", help="only this (dotted) field")
    p.add_argument("--flow-style", action="store_true", help="accepted as ros2 takes it (the output is always flow style)")
    p.set_defaults(run=topic_echo)
    p = topic.add_parser("hz")
    p.add_argument("topic")
    p.add_argument("--seconds", type=float, default=5.0)
    p.set_defaults(run=topic_hz)
    p = topic.add_parser("pub")
    p.add_argument("topic")
    p.add_argument("type")
    p.add_argument("values")
    p.add_argument("-1", "--once", action="store_true", help="accepted as ros2 takes it (this stand-in always publishes once)")
    p.set_defaults(run=topic_pub)
    param = sub.add_parser("param").add_subparsers(dest="verb", required=True)
    p = param.add_parser("get")
    p.add_argument("node")
    p.add_argument("name")
    p.set_defaults(run=param_get)
    p = sub.add_parser("launch")
    p.add_argument("file", help="a launch file of dynamixel_handler, e.g. launch_dynamixel_handler.py")
    p.add_argument("arguments", nargs="*", help="name:=value")
    p.set_defaults(run=launch)
    args = parser.parse_args()
    if args.run is launch:
        launch(args)
        return
    rclpy.init()
    try:
        args.run(args)
    except KeyboardInterrupt:
        pass
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
