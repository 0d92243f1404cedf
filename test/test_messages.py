"""The 36 interface definitions: present, exact constants, and intact across processes."""
from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node

import dynamixel_handler_msgs.msg as msgs

from support.msg_fill import filled
from support.ros import spin_until

HERE = Path(__file__).resolve().parent
MSG_DIR = HERE.parent / "dynamixel_handler_msgs" / "msg"
SPEC = HERE.parent.parent / "shared" / "spec" / "messages.md"

ALL_TYPES = sorted(p.stem for p in MSG_DIR.glob("*.msg"))


def test_there_are_exactly_the_36_messages_of_the_design():
    assert len(ALL_TYPES) == 36
    for name in ALL_TYPES:
        cls = getattr(msgs, name)
        cls()  # constructible with defaults


@pytest.mark.skipif(not SPEC.exists(), reason="design spec not beside the repo")
def test_definitions_match_the_design_text_exactly():
    import re
    blocks = dict(re.findall(r"^### (\w+)\n```\n(.*?)```", SPEC.read_text(), re.S | re.M))
    assert sorted(blocks) == ALL_TYPES
    for name, body in blocks.items():
        ours = [ln.split("#")[0].rstrip() for ln in (MSG_DIR / f"{name}.msg").read_text().splitlines()]
        assert [ln for ln in ours if ln] == [ln.rstrip() for ln in body.splitlines() if ln.strip()], name


def test_constants_and_defaults():
    S, St = msgs.DynamixelShortcut, msgs.DynamixelStatus
    assert (S.CLEAR_ERROR, S.TORQUE_OFF, S.TORQUE_ON, S.REMOVE_ID, S.ADD_ID) == (
        "clear_error", "torque_off", "torque_on", "remove_id", "add_id")
    assert (S.RESET_OFFSET, S.ENABLE, S.DISABLE, S.REBOOT) == ("reset_offset", "enable", "disable", "reboot")
    assert S().command == ""
    assert [St.CONTROL_PWM, St.CONTROL_CURRENT, St.CONTROL_VELOCITY, St.CONTROL_POSITION,
            St.CONTROL_EXTENDED_POSITION, St.CONTROL_CURRENT_BASE_POSITION] == [
        "pwm", "current", "velocity", "position", "ex_position", "cur_position"]
    assert St.CLEAR_KEEP_ROT is True and St.CLEAR is False
    E = msgs.DxlExternalPort
    assert [E.MODE_ANALOG_IN, E.MODE_DIGITAL_OUT, E.MODE_DIGITAL_IN_PULLUP, E.MODE_DIGITAL_IN_PULLDOWN,
            E.MODE_UNSET] == ["a_in", "d_out", "d_in_pu", "d_in_pd", "unset"]
    M = msgs.DynamixelExtraMovingstatus
    assert [M.PROFILE_NONE, M.PROFILE_RECTANGULAR, M.PROFILE_TRIANGULAR, M.PROFILE_TRAPEZOIDAL] == [
        "none", "rectangular", "triangular", "trapezoidal"]
    D = msgs.DynamixelExtraDrivemode
    assert (D.TIME_BASED, D.VELOCITY_BASED) == ("time_based", "velocity_based")


def test_field_types_of_the_big_messages():
    fields = msgs.DxlStates.get_fields_and_field_types()
    assert list(fields) == ["stamp", "status", "present", "goal", "gain", "limit", "error", "extra"]
    assert fields["stamp"] == "builtin_interfaces/Time"
    assert msgs.DxlExternalPort.get_fields_and_field_types()["data"] == "sequence<int16>"
    assert msgs.DynamixelGain.get_fields_and_field_types()["velocity_i_gain_pulse"] == "sequence<uint16>"


@pytest.fixture
def ros_node():
    rclpy.init()
    node = Node("test_msg_roundtrip")
    executor = rclpy.executors.SingleThreadedExecutor()
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()


@pytest.mark.parametrize("type_name", ["DxlStates", "DxlCommandsX", "DxlCommandsAll", "DynamixelDebug", "DxlExternalPort"])
def test_fully_populated_message_round_trips_between_processes(ros_node, type_name):
    node, executor = ros_node
    cls = getattr(msgs, type_name)
    expected = filled(cls)
    got = []
    node.create_subscription(cls, f"/roundtrip/{type_name}", got.append, 10)
    pub = subprocess.Popen([sys.executable, str(HERE / "support" / "msg_fill.py"), type_name, f"/roundtrip/{type_name}"])
    try:
        assert spin_until(node, executor, lambda: bool(got), timeout=20), "no message arrived from the other process"
    finally:
        pub.send_signal(signal.SIGINT)
        pub.wait(10)
    msg = got[0]
    assert msg == expected
    # spot-check that the filler really populated nested arrays (so == compares something)
    if type_name == "DxlStates":
        assert len(msg.extra.moving_status.velocity_profile) == 3 and msg.stamp.sec == -123
        assert msg.present.position_deg[2] == 1e9
