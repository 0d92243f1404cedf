"""The state publishing path's fast paths against the plain path: the same table gives the same
bytes on the wire.

- ``lean.Patcher`` writes each value over the bytes of the previous one: equal to ``Codec.encode``
  (and read by the middleware as the rclpy message built the plain way) over sequences of values
  that keep or replace arrays, change a sequence's length or a string, and give or leave out parts.
- ``convert.Cache`` keeps unit conversions and group messages from loop to loop: the messages it
  gives, encoded by the patcher, are byte for byte those built afresh from the table and encoded
  field by field, over random tables (1 and 30 servos, IDs and models changing between loops,
  items never read, so NaN / unknown), every mix of groups read, and a real handler on a virtual bus.
- ``cdr.Codec`` decoding: a command part that holds strings or nested parts (status, extra) is
  recognised by one compare with the bytes of an empty value; decoded as field by field.
"""
from __future__ import annotations

import inspect
import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

import dynamixel_handler_msgs.msg as msgs
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.ros import convert
from dynamixel_handler.ros.cdr import Codec
from dynamixel_handler.ros.lean import Patcher
from dynamixel_handler.ros.publishers import SAME_NAME, STATE_TOPICS, StatePublishers
from dynamixel_handler.servo.groups import GAIN, GOAL, LIMIT, PRESENT
from dynamixel_handler.servo.table import ServoTable

from support.msg_fill import codec_values, decoded_with, same_value
from support.rig import PRO, X540, P, X

MESSAGES = [c for _, c in inspect.getmembers(msgs, inspect.isclass) if hasattr(c, "get_fields_and_field_types")]


# ============================================================================ the patcher
def read_alike(codec: Codec, ours: bytes, value: dict) -> bool:
    """The middleware reads ``ours`` as the rclpy message built the plain way (NaN equal to NaN)."""
    return same_value(codec.from_message(deserialize_message(ours, codec.msg_class)),
                      codec.from_message(codec.to_message(value)))


@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_patched_bytes_equal_the_plain_encoding_over_a_sequence(msg_class, data):
    codec = Codec.of(msg_class)
    patcher = Patcher(codec)
    value = None
    for _ in range(6):
        value = data.draw(codec_values(codec, value))
        ours = patcher.encode(value)
        assert ours == codec.encode(value)
        assert read_alike(codec, ours, value)


def test_a_writable_array_changed_in_place_is_written_again():
    codec = Codec.of(msgs.DynamixelPresent)
    patcher = Patcher(codec)
    arr = np.array([1.0, 2.0])
    value = {"id_list": [1, 2], "position_deg": arr}
    assert patcher.encode(value) == codec.encode(value)
    arr[1] = 7.5  # the same object, another content
    assert patcher.encode(value) == codec.encode(value)
    kept = np.array([3.0, 4.0])
    kept.setflags(write=False)
    value["position_deg"] = kept
    first = patcher.encode(value)
    assert patcher.encode(dict(value)) == first == codec.encode(value)


def test_the_middleware_reads_the_patched_bytes_as_its_own():
    codec = Codec.of(msgs.DxlStates)
    patcher = Patcher(codec)
    for k in range(5):
        value = {"stamp": {"sec": 100 + k, "nanosec": 999_999_999 - k},
                 "present": {"id_list": [1, 2, 3], "position_deg": [k, np.nan, -k * 0.5]},
                 "status": {"id_list": [1, 2, 3], "mode": ["position", "velocity" if k % 2 else "pwm", ""]}}
        msg = codec.to_message(value)
        assert read_alike(codec, patcher.encode(value), value)
        assert same_value(codec.decode(patcher.encode(value)), codec.decode(serialize_message(msg)))


# ============================================================================ the kept messages
ITEMS = sorted({item for item, _ in PRESENT.values()} | set(GOAL) | set(LIMIT) | set(GAIN)
               | {"operating_mode", "torque_enable", "hardware_error_status", "led", "moving", "moving_status",
                  "drive_mode", "shutdown", "startup_configuration", "protocol_type", "firmware_version"})
MODELS = [model_by_number(n) for n in (X, X540, P, PRO)]
GROUPS = ("status", "goal", "gain", "limit", "error", "extra_dynamic", "extra_static")


def _topics(parts: convert.Parts, table: ServoTable, stamp: float, groups: set[str], present: set[str],
            outdated: bool) -> dict[str, dict]:
    """Every message one loop publishes (all topics subscribed), as ``StatePublishers.messages``."""
    out = {"states": convert.states(table, stamp, groups, present, outdated, parts=parts),
           "debug": convert.debug(table, parts.get("status"), parts.units)}
    for name in StatePublishers._due(groups, present):
        out[name] = parts.get(name)
    return out


def _codec(topic: str) -> Codec:
    types = dict(STATE_TOPICS, states=msgs.DxlStates, debug=msgs.DynamixelDebug)
    return Codec.of(types[topic])


class TwoPaths:
    """The plain path (messages built afresh, encoded field by field) next to the fast one
    (``convert.Cache`` and a ``Patcher`` per topic, kept across loops)."""

    def __init__(self, outdated: bool) -> None:
        self.outdated = outdated
        self.cache = convert.Cache()
        self.patchers: dict[str, Patcher] = {}
        self.compared = 0

    def loop(self, table: ServoTable, stamp: float, groups: set[str], present: set[str]) -> None:
        snap = table.snapshot()  # as the node hands the publishing thread
        plain = _topics(convert.Parts(snap, present, self.outdated), snap, stamp, groups, present, self.outdated)
        fast = _topics(convert.Parts(snap, present, self.outdated, self.cache), snap, stamp, groups, present,
                       self.outdated)
        assert plain.keys() == fast.keys()
        for topic, value in plain.items():
            codec = _codec(topic)
            ours = self.patchers.setdefault(topic, Patcher(codec)).encode(fast[topic])
            assert ours == codec.encode(value), (topic, groups, present, table.ids)
            assert read_alike(codec, ours, value)
            self.compared += 1


def _store_some(table: ServoTable, rng: random.Random, when: float) -> None:
    """New values for some items of some servos (the others keep theirs, or stay unknown)."""
    n = len(table)
    for item in rng.sample(ITEMS, rng.randint(0, len(ITEMS) // 2)):
        positions = np.array(sorted(rng.sample(range(n), rng.randint(0, n))), dtype=np.int64)
        pulses = np.array([rng.randint(-5000, 70000) for _ in positions], dtype=np.int64)
        table.store(item, positions, pulses, when)


@pytest.mark.parametrize("outdated", [True, False], ids=["outdated_present", "present_read_only"])
@pytest.mark.parametrize("seed", range(4))
def test_kept_messages_equal_fresh_ones_over_random_tables(outdated, seed):
    rng = random.Random(seed)
    table = ServoTable()
    paths = TwoPaths(outdated)
    for loop in range(120):
        if loop % 20 == 0 or rng.random() < 0.05:  # the servos change: 1 or 30 of them, or a few
            size = rng.choice((1, 30, rng.randint(1, 6)))
            wanted = set(rng.sample(range(0, 253), size))
            for dxl_id in list(table.ids):
                if dxl_id not in wanted:
                    table.remove(dxl_id)
            for dxl_id in sorted(wanted):
                if dxl_id not in table or rng.random() < 0.1:  # new, or another model under the same ID
                    table.add(dxl_id, rng.choice(MODELS))
        if rng.random() < 0.7:
            _store_some(table, rng, loop * 0.01)
        if rng.random() < 0.3:
            table.ping = np.array([rng.random() < 0.8 for _ in table.ids], dtype=bool)
        groups = {g for g in GROUPS if rng.random() < 0.2}
        present = {k for k in PRESENT if rng.random() < 0.5} if rng.random() < 0.9 else set()
        if groups or present:
            paths.loop(table, 1_700_000_000 + loop * 0.0137, groups, present)
    assert paths.compared > 200


def test_no_servo_at_all_and_nothing_read_yet():
    table = ServoTable()
    paths = TwoPaths(True)
    for loop in range(3):
        paths.loop(table, 5.0 + loop, set(SAME_NAME) | {"extra_static"}, set(PRESENT))
    table.add(3, MODELS[0])  # one servo, nothing of it read: every value unknown
    for loop in range(3):
        paths.loop(table, 9.0 + loop, set(SAME_NAME) | {"extra_dynamic"}, {"position"})


def test_a_handler_on_a_virtual_bus_publishes_the_same_bytes_either_way():
    from dynamixel_handler.bus import DynamixelBus
    from dynamixel_handler.config import defaults, validate
    from dynamixel_handler.core.handler import Handler
    from dynamixel_handler.sim import VirtualBus

    sim = VirtualBus({1: X, 2: X540, 3: P, 4: PRO}, baudrate=1_000_000)
    bus = DynamixelBus(sim.start(), 1_000_000, latency_timer_ms=1.0, retry_num=1)
    bus.open()
    try:
        config = validate({**defaults(), "device_name": sim.path, "init/servo_auto_search.max_id": 4,
                           "init/used_servo_series.P": True, "init/used_servo_series.Pro": True,
                           "init/expected_servo_num": 4, "pub_ratio/status": 3, "pub_ratio/goal": 2,
                           "pub_ratio/gain": 5, "pub_ratio/limit": 7, "pub_ratio/error": 4,
                           "pub_ratio/extra.dynamic_items": 6, "pub_ratio/present.temperature": 3})
        handler = Handler(bus, config)
        handler.start()
        paths = {True: TwoPaths(True), False: TwoPaths(False)}
        for loop in range(40):
            if loop == 15:
                sim.servo(2).write("goal_position", 3000)
            if loop == 25:  # a servo leaves the bus: unanswered reads, ping false
                sim.remove_servo(3)
            report = handler.step()
            if report.groups or report.present:
                for two in paths.values():
                    two.loop(handler.table, report.stamp, report.groups, report.present)
        handler.shutdown()
        assert all(two.compared > 60 for two in paths.values())
    finally:
        bus.close()
        sim.close()


# ============================================================================ command decoding
@pytest.mark.parametrize("msg_class", MESSAGES, ids=lambda c: c.__name__)
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_parts_with_the_bytes_of_an_empty_value_decode_as_field_by_field(msg_class, data, monkeypatch):
    codec = Codec.of(msg_class)
    value = data.draw(codec_values(codec, None))
    for raw in (serialize_message(codec.to_message(value)), codec.encode(value)):
        assert same_value(codec.decode(raw), decoded_with(codec, raw, monkeypatch, lambda c: ("_decode_from", c._decode_fields)))


def test_a_command_bundle_decodes_its_empty_parts_by_one_compare_each(monkeypatch):
    codec = Codec.of(msgs.DxlCommandsX)
    msg = msgs.DxlCommandsX()
    msg.position_control.id_list = [1, 2]
    msg.position_control.position_deg = [10.0, -5.0]
    raw = serialize_message(msg)
    calls = []
    for name in ("status", "extra"):  # parts with strings or nested parts: not sequences only
        part = codec.fields[[f[0] for f in codec.fields].index(name)][2]
        assert part._no_elements is None
        monkeypatch.setattr(part, "_decode_fields", lambda *a, p=part: calls.append(p) or Codec._decode_fields(p, *a))
    first, second = codec.decode(raw), codec.decode(raw)
    assert calls == []  # both recognised without walking their fields
    monkeypatch.undo()
    assert same_value(first, decoded_with(codec, raw, monkeypatch, lambda c: ("_decode_from", c._decode_fields)))
    first["status"]["mode"].append("x")  # every decoded value has its own lists and dicts
    first["extra"]["led"]["red_percent"] = None
    assert second["status"]["mode"] == [] and len(second["extra"]["led"]["red_percent"]) == 0
    # a part that is not empty, or empty but written another way (a string of length 0), is decoded
    msg.status.mode = ["position"]
    assert codec.decode(serialize_message(msg))["status"]["mode"] == ["position"]


# ============================================================================ subscription counts
def test_a_subscriber_is_noticed_within_the_recheck_time():
    """``TreePublisher.wanted`` asks the middleware at most every ``RECHECK_S``: a subscriber that
    comes (or goes) is noticed that long after the middleware counts it, at most."""
    import time

    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    from dynamixel_handler.ros.lean import RECHECK_S, TreePublisher

    assert RECHECK_S <= 0.5
    context = Context()
    rclpy.init(context=context)
    try:
        node = Node("wanted_check", context=context)
        pub = TreePublisher(node, msgs.DynamixelDebug, "wanted_check/debug", 10, True)
        assert not pub.wanted()

        def noticed(want: bool) -> float:
            """Seconds from the middleware's count to ``wanted()`` saying so."""
            deadline = time.monotonic() + 10
            while (pub.publisher.get_subscription_count() > 0) != want:
                assert time.monotonic() < deadline, "the middleware never counted the change"
                time.sleep(0.001)
            counted = time.monotonic()
            while pub.wanted() != want:
                assert time.monotonic() - counted < RECHECK_S + 0.05
                time.sleep(0.001)
            return time.monotonic() - counted

        sub = node.create_subscription(msgs.DynamixelDebug, "wanted_check/debug", lambda _m: None, 10)
        noticed(True)
        node.destroy_subscription(sub)
        noticed(False)
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_two_threads_sharing_a_patcher_get_the_plain_bytes():
    """A publishing thread of a restarted loop may still run: each encoding is whole."""
    import sys
    import threading

    codec = Codec.of(msgs.DynamixelPresent)
    patcher = Patcher(codec)
    values = [{"id_list": list(range(1, n + 1)), "position_deg": np.arange(n) * k * 0.5,
               "current_ma": np.arange(n) - k} for k in range(60) for n in (12, 12, 12, 3)]
    expected = [codec.encode(v) for v in values]
    wrong: list[int] = []

    def run(offset: int) -> None:
        for _ in range(30):
            for k in range(offset, len(values), 2):
                if patcher.encode(values[k]) != expected[k]:
                    wrong.append(k)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=run, args=(i,)) for i in (0, 1)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    assert wrong == []


def test_the_states_stamp_is_the_node_clocks_with_and_without_simulated_time():
    """Without a simulated clock the reads' wall time is the stamp as is (the node's clock is the
    wall clock); with one, the stamp follows it (``ros_time``)."""
    import time

    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from rclpy.time import Time

    from dynamixel_handler.ros.node import DynamixelHandlerNode

    class Stamps(Node):  # the node's own two methods, on a node without a bus
        ros_time = DynamixelHandlerNode.ros_time
        _states_stamp = DynamixelHandlerNode._states_stamp

    context = Context()
    rclpy.init(context=context)
    try:
        node = Stamps("stamp_check", context=context)
        wall = time.time() - 0.004
        assert not node.get_clock().ros_time_is_active
        assert node._states_stamp(wall) == wall
        assert abs(node.ros_time(wall) - wall) < 2e-3
        node.get_clock()._set_ros_time_is_active(True)  # as use_sim_time's time source does
        node.get_clock().set_ros_time_override(Time(seconds=50))
        wall = time.time() - 0.5
        assert abs(node._states_stamp(wall) - 49.5) < 2e-3
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


# ============================================================================ loops of present values only
@pytest.mark.parametrize("outdated", [True, False], ids=["outdated_present", "present_read_only"])
def test_loops_of_present_values_only_send_the_plain_bytes(outdated):
    """``publishers.Frame``: a loop that read present values only writes the stamp and the items
    read again over the bytes of the last such loop; what goes out equals the plain path's
    encoding of messages built afresh, loop after loop (IDs, models, status, goals and the set of
    items read changing in between), and most loops take the frame."""
    import time

    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    from dynamixel_handler.core.handler import StepReport

    context = Context()
    rclpy.init(context=context)
    try:
        node = Node("frame_check", context=context)
        pubs = StatePublishers(node, raw=True, per_group=True, outdated_present=outdated)
        names = {pubs.states: "states", pubs.debug: "debug", **{p: n for n, p in pubs.by_group.items()}}
        subs = [node.create_subscription(p.codec.msg_class, p.publisher.topic_name, lambda _m: None, 10, raw=True)
                for p in names]
        deadline = time.monotonic() + 10
        while not all(p.wanted() for p in names):
            assert time.monotonic() < deadline, "the subscriptions were never counted"
            time.sleep(0.01)
        rng = random.Random(7)
        table = ServoTable()
        framed = compared = 0
        for loop in range(400):
            if loop % 60 == 0 or rng.random() < 0.02:
                for dxl_id in list(table.ids):
                    if rng.random() < 0.5:
                        table.remove(dxl_id)
                for dxl_id in rng.sample(range(1, 40), rng.choice((1, 3, 30))):
                    if dxl_id not in table or rng.random() < 0.2:
                        table.add(dxl_id, rng.choice(MODELS))
            present = set(rng.sample(sorted(PRESENT), 3)) if rng.random() < 0.2 else {"current", "velocity", "position"}
            for key in present:
                item = PRESENT[key][0]
                n = len(table)
                table.store(item, np.arange(n), np.array([rng.randint(-3000, 3000) for _ in range(n)]), loop)
            if rng.random() < 0.05:
                _store_some(table, rng, loop)  # goals, status items... changed between reads
            if rng.random() < 0.05:
                table.ping = np.array([rng.random() < 0.9 for _ in table.ids], dtype=bool)
            groups = {rng.choice(GROUPS)} if rng.random() < 0.1 else set()
            stamp = 1_700_000_000 + loop * 0.0123
            snap = table.snapshot()
            batch = pubs.messages(StepReport(loop=loop, stamp=stamp, groups=groups, present=present), snap, stamp)
            plain = _topics(convert.Parts(snap, present, outdated), snap, stamp, groups, present, outdated)
            assert [names[p] for p, _ in batch] == list(plain)
            for pub, value in batch:  # as TreePublisher.publish sends it
                framed += type(value) is bytes
                ours = value if type(value) is bytes else pub.patcher.encode(value)
                codec = pub.codec
                assert ours == codec.encode(plain[names[pub]]), (loop, names[pub], groups, present)
                compared += 1
        assert compared > 900 and framed > compared / 3, (compared, framed)
        for sub in subs:
            node.destroy_subscription(sub)
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
