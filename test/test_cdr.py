"""The handler's own CDR reader/writer (dynamixel_handler/ros/cdr.py) against the middleware's.

Every message of the package, filled with random values, must read back identically both ways:
bytes written by rclpy decode here to the same values, and bytes written here are read by rclpy as
the same message. Hand-written packets pin the layout independently of both, and broken or
foreign bytes are refused with DecodeError, never anything else.
"""
from __future__ import annotations

import inspect
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

import dynamixel_handler_msgs.msg as msgs
from dynamixel_handler.ros.cdr import Codec, DecodeError, Unsupported, sample, self_check
from dynamixel_handler_msgs.msg import DxlCommandsX, DynamixelControlXPosition, DynamixelShortcut, DynamixelStatus

MESSAGES = [c for _, c in inspect.getmembers(msgs, inspect.isclass) if hasattr(c, "get_fields_and_field_types")]

_INT_RANGE = {"u1": (0, 255), "i1": (-128, 127), "u2": (0, 65535), "i2": (-32768, 32767),
              "u4": (0, 2**32 - 1), "i4": (-2**31, 2**31 - 1), "u8": (0, 2**64 - 1), "i8": (-2**63, 2**63 - 1)}
_TEXT = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=12)


def _number(code: str):
    if code == "?":
        return st.booleans()
    if code[0] == "f":  # finite: NaN != NaN would make rclpy's message equality fail
        return st.floats(allow_nan=False, allow_infinity=True, width=32 if code == "f4" else 64)
    lo, hi = _INT_RANGE[code]
    return st.integers(lo, hi)


def values_of(codec: Codec) -> st.SearchStrategy:
    fields = {}
    for name, kind, detail in codec.fields:
        if kind == "message":
            fields[name] = values_of(detail)
        elif kind == "array":
            code = detail[0]
            fields[name] = st.lists(_number(code), max_size=6).map(lambda v, c=code: np.array(v, dtype=c))
        elif kind == "strings":
            fields[name] = st.lists(_TEXT, max_size=4)
        elif kind == "string":
            fields[name] = _TEXT
        else:
            fields[name] = _number(detail[0])
    return st.fixed_dictionaries(fields)


def same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b)) and len(a) == len(b)
    return a == b


def test_every_message_of_the_package_is_covered():
    assert len(MESSAGES) == 36
    assert self_check(MESSAGES) is None


@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_round_trip_both_ways_with_the_middleware(msg_class, data):
    codec = Codec.of(msg_class)
    value = data.draw(values_of(codec))
    msg = codec.to_message(value)
    # bytes written here, read by the middleware
    assert deserialize_message(codec.encode(value), msg_class) == msg
    # bytes written by the middleware, read here
    decoded = codec.decode(serialize_message(msg))
    assert same(codec.from_message(msg), decoded)
    assert same(value, decoded)


def test_hand_written_little_endian_packet():
    # DynamixelControlXPosition: id_list [1, 2], position_deg [90.0], the two profiles empty
    packet = (b"\x00\x01\x00\x00" + struct.pack("<I", 2) + struct.pack("<HH", 1, 2)
              + struct.pack("<I", 1) + b"\x00" * 4 + struct.pack("<d", 90.0)  # pad to 8 from the payload start
              + struct.pack("<I", 0) + struct.pack("<I", 0))
    value = Codec.of(DynamixelControlXPosition).decode(packet)
    assert value["id_list"].tolist() == [1, 2]
    assert value["position_deg"].tolist() == [90.0]
    assert len(value["profile_vel_deg_s"]) == 0 and len(value["profile_acc_deg_ss"]) == 0
    assert Codec.of(DynamixelControlXPosition).encode(value) == packet
    assert deserialize_message(packet, DynamixelControlXPosition) == DynamixelControlXPosition(
        id_list=[1, 2], position_deg=[90.0])


def test_hand_written_big_endian_packet():
    # DynamixelShortcut written by a big-endian machine: command "torque_on", id_list [3]
    text = b"torque_on\x00"
    packet = (b"\x00\x00\x00\x00" + struct.pack(">I", len(text)) + text + b"\x00\x00"
              + struct.pack(">I", 1) + struct.pack(">H", 3))
    value = Codec.of(DynamixelShortcut).decode(packet)
    assert value["command"] == "torque_on"
    assert value["id_list"].tolist() == [3]


def test_strings_sequences_and_booleans_layout():
    value = {"id_list": [7], "torque": [True], "error": [False], "ping": [True, True], "mode": ["ab", ""]}
    packet = Codec.of(DynamixelStatus).encode(value)
    expected = (b"\x00\x01\x00\x00" + struct.pack("<IH", 1, 7) + b"\x00\x00" + struct.pack("<I", 1) + b"\x01"
                + b"\x00" * 3 + struct.pack("<I", 1) + b"\x00" + b"\x00" * 3 + struct.pack("<I", 2) + b"\x01\x01"
                + b"\x00\x00" + struct.pack("<I", 2) + struct.pack("<I", 3) + b"ab\x00" + b"\x00"
                + struct.pack("<I", 1) + b"\x00")
    assert packet[:len(expected)] == expected and len(packet) - len(expected) < 4
    assert deserialize_message(packet, DynamixelStatus) == DynamixelStatus(
        id_list=[7], torque=[True], error=[False], ping=[True, True], mode=["ab", ""])


@pytest.mark.parametrize("msg_class", [DxlCommandsX, DynamixelShortcut, DynamixelStatus], ids=lambda c: c.__name__)
def test_every_truncation_is_refused_cleanly(msg_class):
    codec = Codec.of(msg_class)
    packet = codec.encode(sample(codec, 3))
    full = codec.decode(packet)
    for cut in range(len(packet)):
        try:
            value = codec.decode(packet[:cut])
        except DecodeError:
            continue
        # a cut inside the trailing padding or the last empty fields may still be a whole message
        assert same(value, full), f"cut at {cut} decoded to something else"


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200))
def test_garbage_is_refused_with_decode_error_only(blob):
    for msg_class in (DxlCommandsX, DynamixelShortcut):
        try:
            Codec.of(msg_class).decode(blob)
        except DecodeError:
            pass


def test_foreign_encapsulation_is_refused():
    codec = Codec.of(DynamixelShortcut)
    packet = bytearray(codec.encode({"command": "reboot", "id_list": [1]}))
    packet[1] = 0x07  # XCDR2 little endian: not read here (the node lets rclpy read it)
    with pytest.raises(DecodeError, match="0x0007"):
        codec.decode(bytes(packet))


def test_types_outside_the_codec_are_reported_not_guessed():
    from sensor_msgs.msg import CameraInfo  # fixed-size arrays (double[9])
    with pytest.raises(Unsupported, match="CameraInfo"):
        Codec(CameraInfo)
