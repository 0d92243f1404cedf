"""The loop's fast paths against their plain counterparts: the same input gives the same bytes,
states and writes.

- CDR encoding (``ros/cdr.py``): groups left out of a message (a loop that did not read them) are
  written from a cache of empty encodings, equal to the field-by-field encoding at every alignment;
  the middleware reads the same message from the bytes, with any mix of fields given or left out.
- CDR decoding: a command part whose sequences are all empty is recognised by one compare of its
  zero counts; the decoded value equals the field-by-field decoding, for the middleware's bytes and
  for this codec's, whatever the padding bytes hold.
- Goal positions (``commands/goal_bounds.py``): those the servo table shows within their bounds are checked
  all at once; the same command sequence on two fresh buses, one per path, leaves the same
  registers on the simulated servos and the same warnings.
- Sync read replies (``core/read_plan.py``): decoded through a record dtype, equal to the byte-by-byte
  decoding for every layout of 1/2/4-byte items, signed or not, and any reply bytes.
"""
from __future__ import annotations

import inspect

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

import dynamixel_handler_msgs.msg as msgs
from dynamixel_handler.core.read_plan import Read as _Read
from dynamixel_handler.core.read_plan import ReadPart as _Part
from dynamixel_handler.core.read_plan import _record, decode_replies, decode_replies_plain
from dynamixel_handler.ros.cdr import Codec

from support.msg_fill import codec_values, decoded_with, same_value
from support.servo_access import attached

MESSAGES = [c for _, c in inspect.getmembers(msgs, inspect.isclass) if hasattr(c, "get_fields_and_field_types")]
@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_encoded_bytes_are_the_middlewares_with_fields_left_out(msg_class, data):
    codec = Codec.of(msg_class)
    value = data.draw(codec_values(codec, nan=False))
    msg = codec.to_message(value)
    ours = codec.encode(value)
    # the same message for the middleware, and the same fields as its own bytes (its padding
    # bytes are not always zero, so the bytes themselves are compared field by field)
    assert deserialize_message(ours, msg_class) == msg
    assert same_value(codec.decode(ours), codec.decode(serialize_message(msg)))


@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
def test_cached_empty_message_equals_the_field_by_field_encoding(msg_class):
    codec = Codec.of(msg_class)
    for shift in range(16):  # every offset modulo 8, twice: the second time from the cache
        cached, plain = bytearray(4 + shift), bytearray(4 + shift)
        codec._encode_empty(cached)
        codec._encode_into(plain, {})
        assert cached == plain, shift


@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_decoding_with_empty_parts_equals_field_by_field(msg_class, data, monkeypatch):
    codec = Codec.of(msg_class)
    value = data.draw(codec_values(codec, nan=False))
    for raw in (serialize_message(codec.to_message(value)), codec.encode(value)):
        fast = codec.decode(raw)
        # the empty-part compare switched off in every nested codec
        assert same_value(fast, decoded_with(codec, raw, monkeypatch, lambda c: ("_no_elements", None)))


def test_an_empty_command_part_is_decoded_by_the_compare():
    codec = Codec.of(msgs.DxlCommandsX)
    raw = codec.encode({"position_control": {"id_list": [1], "position_deg": [10.0]}})
    part = codec.fields[[f[0] for f in codec.fields].index("velocity_control")][2]
    assert part._no_elements is not None
    value = codec.decode(raw)
    assert value["position_control"]["position_deg"].tolist() == [10.0]
    assert all(len(v) == 0 for v in value["velocity_control"].values())


@st.composite
def reads_and_replies(draw):
    """A sync read of 1-5 items (sizes 1, 2 or 4, gaps between them) and 0-12 servos' replies."""
    parts, offset = [], 0
    for k in range(draw(st.integers(1, 5))):
        offset += draw(st.integers(0, 3))
        size = draw(st.sampled_from((1, 2, 4)))
        parts.append(_Part(f"item{k}", offset, size, draw(st.booleans())))
        offset += size
    length = offset + draw(st.integers(0, 2))
    n = draw(st.integers(0, 12))
    read = _Read(100, length, tuple(range(1, n + 1)), tuple(parts))
    return read, draw(st.binary(min_size=n * length, max_size=n * length))


@settings(max_examples=300, deadline=None)
@given(case=reads_and_replies())
def test_reply_decoding_through_a_record_equals_byte_by_byte(case):
    read, joined = case
    assert _record(read.length, read.parts) is not None  # the fast path is the one taken
    fast, plain = decode_replies(read, joined), decode_replies_plain(read, joined)
    assert len(fast) == len(plain) == len(read.parts)
    for a, b in zip(fast, plain):
        assert a.dtype == b.dtype == np.int64
        assert a.tolist() == b.tolist()


def test_reply_decoding_of_known_bytes():
    """Present position -1 (signed 4 bytes) and a temperature of 40 (unsigned 1 byte), two servos."""
    read = _Read(132, 14, (1, 2), (_Part("present_position", 0, 4, True), _Part("present_temperature", 13, 1, False)))
    joined = bytes.fromhex("ffffffff" + "00" * 9 + "28") + bytes.fromhex("00080000" + "00" * 9 + "ff")
    assert [v.tolist() for v in decode_replies(read, joined)] == [[-1, 2048], [40, 255]]


# ============================================================================ goal position bounds
def _run_goal_sequence(vector: bool, monkeypatch) -> tuple[list[dict[int, int]], list[str]]:
    """One command sequence on a fresh virtual bus (X, X540, P, Pro); the goal position registers
    after each command and every warning line."""
    from dynamixel_handler.commands import Commander, CommandPaths, goal_bounds

    from support.handler_bench import capture_log, handler_on_virtual_bus
    from support.rig import PRO, X540, P, X

    config = {"mode_change_interval_sec": 0.0, "pub_ratio/limit": 1, "pub_ratio/status": 1,
              "init/used_servo_series.P": True, "init/used_servo_series.Pro": True, "init/expected_servo_num": 4}
    with handler_on_virtual_bus({1: X, 2: X540, 3: P, 4: PRO}, config, baudrate=1_000_000, patient=True) as (sim, handler):
        lines = capture_log(handler, f"goal_bounds_{vector}")
        commander = attached(Commander(handler, CommandPaths(bounds=vector)))
        registers = []
        steps = [
            lambda: commander.control("X", "position_control", [1, 2], {"position_deg": [10.0, 400.0]}),
            lambda: commander.control("P", "position_control", [3], {"position_deg": [-500.0]}),
            lambda: commander.control("PRO", "position_control", [4], {"position_deg": [45.0]}),
            lambda: commander.goal([1, 2, 3, 4], {"position_deg": [-200.0, 30.0, 170.0, 1e4]}),
            # limits the wrong way round on servo 1: its register range applies (X)
            lambda: (sim.servo(1).write("min_position_limit", 3000), sim.servo(1).write("max_position_limit", 1000)),
            lambda: commander.goal([1, 2], {"position_deg": [170.0, -5.0]}),
            lambda: commander.control("X", "extended_position_control", [2, 1], {"position_deg": [1e6, -720.0]}),
            lambda: commander.goal([2, 1, 2], {"position_deg": [-1e7, 5.0, 20.0]}),
            lambda: commander.control("P", "extended_position_control", [3], {"position_deg": [1e6]}),
            lambda: commander.goal([3, 4], {"position_deg": [-1e6, -170.0]}),
        ]
        for step in steps:
            step()
            handler.step()
            handler.step()
            registers.append({i: sim.servo(i).read("goal_position") for i in range(1, 5)})
        if vector:  # the fast path was taken: the table knew what the bounds need
            assert goal_bounds.goal_position_bounds(handler.table, [1, 2, 3, 4]) is not None
        handler.shutdown()
        return registers, [line for line in lines if "clamped" in line or "refused" in line or "ignored" in line]


def test_goal_positions_checked_at_once_equal_servo_by_servo(monkeypatch):
    fast_registers, fast_lines = _run_goal_sequence(True, monkeypatch)
    plain_registers, plain_lines = _run_goal_sequence(False, monkeypatch)
    assert fast_registers == plain_registers
    assert fast_lines == plain_lines
    assert sum("clamped" in line for line in plain_lines) >= 4, plain_lines  # both branches were used
    assert fast_registers[0][1] == 2048 + round(10 / (360 / 4096))  # a goal within bounds as sent
