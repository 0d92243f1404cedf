#!/usr/bin/env python3
"""Stand-ins for a few `ros2` commands where the ROS 2 command line is not installed.

The `ros2` command (ros2cli) and `launch` are not on PyPI, so a machine set up from the PyPI wheels
(scripts/setup.sh) has rclpy but no `ros2`. This script does what these commands do, with rclpy:

    python scripts/ros_cli.py topic echo /dynamixel/states [--once] [--field present.position_deg]
    python scripts/ros_cli.py topic hz /dynamixel/states [--seconds 5]
    python scripts/ros_cli.py topic pub /dynamixel/shortcut dynamixel_handler_msgs/msg/DynamixelShortcut \\
        "{command: 'TON', id_list: [1]}"
    python scripts/ros_cli.py param get /dynamixel_handler loop_rate
    python scripts/ros_cli.py param describe /dynamixel_handler loop_rate
    python scripts/ros_cli.py param set /dynamixel_handler verbose_ratio 100
    python scripts/ros_cli.py service list
    python scripts/ros_cli.py service call /dynamixel/set_torque dynamixel_handler_msgs/srv/SetTorque \
        "{ids: [1], enable: true}"
    python scripts/ros_cli.py action send_goal /dynamixel/move_joints dynamixel_handler_msgs/action/MoveJoints \
        "{ids: [1], positions_deg: [30.0]}" [--feedback]
    python scripts/ros_cli.py lifecycle get /dynamixel_handler
    python scripts/ros_cli.py lifecycle set /dynamixel_handler configure
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


def _type(name: str, kind: str = "msg"):
    """``pkg/msg/Name`` (or ``pkg/Name``), ``pkg/srv/Name``, ``pkg/action/Name`` -> the class."""
    package, _, cls = name.replace(f"/{kind}/", "/").partition("/")
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), cls)
    except (ImportError, AttributeError):
        sys.exit(f"unknown {kind} type {name!r}")


def _call(node: Node, client, request, what: str, timeout: float = 30.0):
    """Wait for the server, send, wait for the answer (or exit naming what did not answer)."""
    if not client.wait_for_service(timeout_sec=10):
        sys.exit(f"{what}: no server")
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
    if not future.done():
        sys.exit(f"{what}: no answer within {timeout:.0f} s")
    return future.result()


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


def param_describe(args) -> None:
    from rcl_interfaces.srv import DescribeParameters
    node = Node("ros_cli_param")
    answer = _call(node, node.create_client(DescribeParameters, f"{args.node}/describe_parameters"),
                   DescribeParameters.Request(names=[args.name]), f"{args.node}/describe_parameters")
    kinds = {0: "not set", 1: "boolean", 2: "integer", 3: "double", 4: "string", 5: "byte array",
             6: "boolean array", 7: "integer array", 8: "double array", 9: "string array"}
    for d in answer.descriptors:
        print(f"Parameter name: {d.name}\n  Type: {kinds.get(d.type, d.type)}\n  Description: {d.description}")
        print("  Constraints:")
        if d.read_only:
            print("    Read only: true")
        if d.additional_constraints:
            print(f"    Additional constraints: {d.additional_constraints}")


def param_set(args) -> None:
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    node = Node("ros_cli_param")
    client = AsyncParameterClient(node, args.node)
    if not client.wait_for_services(timeout_sec=10):
        sys.exit(f"node {args.node} not found")
    future = client.set_parameters([Parameter(args.name, value=yaml.safe_load(args.value))])
    rclpy.spin_until_future_complete(node, future, timeout_sec=10)
    result = future.result().results[0]
    print("Set parameter successful" if result.successful else f"Setting parameter failed: {result.reason}")


def service_list(args) -> None:
    node = Node("ros_cli_service")
    end = time.monotonic() + args.seconds  # discovery needs a moment
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
    for name, types in sorted(node.get_service_names_and_types()):
        if "/ros_cli_" not in name:
            print(f"{name} [{', '.join(types)}]" if args.show_types else name)


def service_call(args) -> None:
    node = Node("ros_cli_service")
    typ = _type(args.type, "srv")
    request = _fill(typ.Request(), yaml.safe_load(args.values or "") or {})
    print(f"requester: making request: {request}\n")
    print(f"response:\n{_call(node, node.create_client(typ, args.service), request, args.service)}\n")


def action_send_goal(args) -> None:
    from rclpy.action import ActionClient
    node = Node("ros_cli_action")
    typ = _type(args.type, "action")
    client = ActionClient(node, typ, args.action)
    if not client.wait_for_server(timeout_sec=10):
        sys.exit(f"{args.action}: no server")
    goal = _fill(typ.Goal(), yaml.safe_load(args.values or "") or {})
    show = (lambda m: print(f"Feedback:\n    {m.feedback}")) if args.feedback else None
    sent = client.send_goal_async(goal, feedback_callback=show)
    rclpy.spin_until_future_complete(node, sent, timeout_sec=10)
    handle = sent.result()
    if handle is None or not handle.accepted:
        sys.exit("Goal was rejected.")
    print(f"Goal accepted with ID: {bytes(handle.goal_id.uuid).hex()}\n")
    result = handle.get_result_async()
    while rclpy.ok() and not result.done():
        rclpy.spin_once(node, timeout_sec=0.1)
    from action_msgs.msg import GoalStatus
    names = {v: k[len("STATUS_"):] for k, v in vars(GoalStatus).items() if k.startswith("STATUS_") and isinstance(v, int)}
    status = result.result().status
    print(f"Result:\n    {result.result().result}\n\nGoal finished with status: {names.get(status, status)}")


def lifecycle_get(args) -> None:
    from lifecycle_msgs.srv import GetState
    node = Node("ros_cli_lifecycle")
    answer = _call(node, node.create_client(GetState, f"{args.node}/get_state"), GetState.Request(),
                   f"{args.node}/get_state")
    print(f"{answer.current_state.label} [{answer.current_state.id}]")


def lifecycle_set(args) -> None:
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState
    ids = {name.lower(): value for name, value in vars(Transition).items()
           if name.startswith("TRANSITION_") and isinstance(value, int)}
    key = f"transition_{args.transition.lower()}"
    if key not in ids:
        sys.exit(f"unknown transition {args.transition!r} (configure, activate, deactivate, cleanup, "
                 "unconfigured_shutdown, inactive_shutdown, active_shutdown)")
    node = Node("ros_cli_lifecycle")
    request = ChangeState.Request(transition=Transition(id=ids[key]))
    answer = _call(node, node.create_client(ChangeState, f"{args.node}/change_state"), request,
                   f"{args.node}/change_state")
    print("Transitioning successful" if answer.success else "Transitioning failed")
    if not answer.success:
        sys.exit(1)


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
    p = param.add_parser("describe")
    p.add_argument("node")
    p.add_argument("name")
    p.set_defaults(run=param_describe)
    p = param.add_parser("set")
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value", help="YAML, as ros2 param set takes it")
    p.set_defaults(run=param_set)
    service = sub.add_parser("service").add_subparsers(dest="verb", required=True)
    p = service.add_parser("list")
    p.add_argument("-t", "--show-types", action="store_true")
    p.add_argument("--seconds", type=float, default=2.0, help="discovery time")
    p.set_defaults(run=service_list)
    p = service.add_parser("call")
    p.add_argument("service")
    p.add_argument("type", help="e.g. std_srvs/srv/Trigger")
    p.add_argument("values", nargs="?", help="the request in YAML")
    p.set_defaults(run=service_call)
    action = sub.add_parser("action").add_subparsers(dest="verb", required=True)
    p = action.add_parser("send_goal")
    p.add_argument("action")
    p.add_argument("type", help="e.g. dynamixel_handler_msgs/action/MoveJoints")
    p.add_argument("values", nargs="?", help="the goal in YAML")
    p.add_argument("-f", "--feedback", action="store_true")
    p.set_defaults(run=action_send_goal)
    lifecycle = sub.add_parser("lifecycle").add_subparsers(dest="verb", required=True)
    p = lifecycle.add_parser("get")
    p.add_argument("node")
    p.set_defaults(run=lifecycle_get)
    p = lifecycle.add_parser("set")
    p.add_argument("node")
    p.add_argument("transition", help="configure, activate, deactivate, cleanup, ..._shutdown")
    p.set_defaults(run=lifecycle_set)
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
