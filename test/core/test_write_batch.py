"""WriteBatch: what the pending values become on the wire (one sync write per item, adjacent items
merged), and that values taken are not lost by a loop that fails before sending them."""
from __future__ import annotations

import logging

from dynamixel_handler.core.write_batch import WriteBatch
from dynamixel_handler.servo.table import PendingWrites

from support.fake_bus import H54, XM430, FakeBus, table_of


def batch(servos, split_write=True, lines: list[str] | None = None):
    bus = FakeBus(servos)
    table = table_of(bus)
    log = logging.getLogger(f"test_write_batch_{id(bus)}")
    if lines is not None:
        log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    pending = PendingWrites()
    return bus, table, pending, WriteBatch(bus, table, pending, log, split_write)


def test_pending_goals_go_out_as_one_sync_write_per_item_and_layout_in_little_endian():
    bus, table, pending, writes = batch({1: XM430, 2: XM430, 3: H54})
    pending.put("goal_position", {1: 1000, 2: -5, 3: 70000})
    writes.send()
    assert sorted(bus.of("sync_write")) == [
        ("sync_write", 116, 4, {1: (1000).to_bytes(4, "little", signed=True), 2: (-5).to_bytes(4, "little", signed=True)}),
        ("sync_write", 596, 4, {3: (70000).to_bytes(4, "little", signed=True)}),
    ]
    assert table.value("goal_position", 2) == -5  # the table holds what the host set
    assert bus.get(2, "goal_position") == -5 and not pending


def test_back_to_back_items_to_the_same_servos_are_merged_unless_split_write():
    for split, expected in ((False, [(108, 12)]), (True, [(108, 4), (112, 4), (116, 4)])):
        bus, _, pending, writes = batch({1: XM430, 2: XM430}, split_write=split)
        for item, base in (("profile_acceleration", 10), ("profile_velocity", 20), ("goal_position", 30)):
            pending.put(item, {1: base + 1, 2: base + 2})
        writes.send()
        assert [(c[1], c[2]) for c in bus.of("sync_write")] == expected
        assert [bus.get(2, i) for i in ("profile_acceleration", "profile_velocity", "goal_position")] == [12, 22, 32]


def test_values_taken_before_a_loop_failed_are_sent_with_the_next_and_a_later_value_wins():
    bus, _, pending, writes = batch({1: XM430, 2: XM430})
    pending.put("goal_position", {1: 100, 2: 200})
    writes.encode_writes()              # taken and built while a read is on the wire ...
    assert writes.writes_ready and not pending and not bus.calls
    # ... the loop fails here: nothing was sent; the next loop has a newer goal for servo 2
    pending.put("goal_position", {2: 222})
    writes.send()
    assert bus.of("sync_write") == [("sync_write", 116, 4, {1: (100).to_bytes(4, "little"), 2: (222).to_bytes(4, "little")})]
    writes.send()
    assert len(bus.of("sync_write")) == 1  # sent once only


def test_a_servo_removed_before_the_send_is_left_out_and_a_value_too_large_is_refused_with_a_line():
    lines: list[str] = []
    bus, table, pending, writes = batch({1: XM430, 2: XM430}, lines=lines)
    pending.put("goal_position", {1: 5, 2: 6})
    pending.put("torque_enable", {1: 300, 2: 1})  # 300 does not fit torque_enable's byte
    writes.encode_writes()
    table.remove(1)
    writes.send()
    assert bus.of("sync_write") == [("sync_write", 64, 1, {2: b"\x01"}), ("sync_write", 116, 4, {2: (6).to_bytes(4, "little")})]
    assert lines == ["ID 1: torque_enable=300 does not fit its 1 bytes: not written"]


def test_a_failed_sync_write_is_reported_once_a_second_per_item_and_reason():
    lines: list[str] = []
    bus, table, pending, writes = batch({1: XM430}, lines=lines)
    bus.fail_sync_writes = True
    for value in (1, 2, 3):
        pending.put("goal_position", {1: value})
        writes.send()
    # the first write failed on the line: the bus takes the device as lost and sends nothing more
    assert len(bus.of("sync_write")) == 1 and not bus.is_open
    assert lines == ["sync write @116x4 to IDs [1] failed: device lost"]
    assert table.value("goal_position", 1) == 3  # the table keeps what the host asked for
