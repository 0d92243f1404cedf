"""ServoIO and GroupIO: one servo's items and mode (a Protocol 1.0 servo's by its Angle Limits),
torque on without a jump, one item of many servos in one sync transaction per control-table layout,
a snapshot's items read in spans."""
from __future__ import annotations

import logging

from dynamixel_handler.bus.result import Failure
from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.group_io import GroupIO
from dynamixel_handler.core.servo_io import ServoIO

from support.fake_bus import H54, XM430, FakeBus, table_of

LOG = logging.getLogger("test_servo_io")


def test_a_read_or_written_value_is_kept_in_the_table_and_a_failed_one_is_not():
    bus = FakeBus({1: XM430, 2: XM430})
    table = table_of(bus)
    io = ServoIO(bus, table, LOG)
    bus.set(1, "present_temperature", 41)
    assert io.read_item(1, "present_temperature") == 41 and table.value("present_temperature", 1) == 41
    assert io.value(1, "present_temperature") == 41 and len(bus.of("read")) == 1  # known: not read again
    bus.silent.add(2)
    assert io.read_item(2, "present_temperature") is None and table.value("present_temperature", 2) is None
    assert not io.write_item(2, "led", 1) and table.value("led", 2) is None
    bus.calls.clear()
    assert not io.write_item(1, "no_such_item", 1) and not bus.calls


def test_torque_on_first_sets_the_goal_to_where_the_servo_is_within_its_limits():
    bus = FakeBus({1: XM430, 2: XM430})
    table = table_of(bus)
    io = ServoIO(bus, table, LOG)
    bus.set(1, "operating_mode", OPERATING_MODES["position"])
    bus.set(1, "present_position", -20)
    bus.set(1, "min_position_limit", 0)
    bus.set(1, "max_position_limit", 4095)
    bus.set(2, "operating_mode", OPERATING_MODES["pwm"])
    assert io.torque_on(1) and io.torque_on(2)
    assert [w[1:] for w in bus.item_writes()] == [("goal_position", (1, 0)), ("torque_enable", (1, 1)),
                                                  ("goal_pwm", (2, 0)), ("torque_enable", (2, 1))]
    assert io.mode(1) == "position" and io.mode(2) == "pwm"


def test_one_item_of_many_servos_is_one_sync_write_and_one_sync_read_per_layout():
    bus = FakeBus({1: XM430, 2: XM430, 3: H54})
    table = table_of(bus)
    group = GroupIO(bus, table, LOG)
    group.write_group("goal_position", {1: 10, 2: 20, 3: 30})
    assert sorted(bus.item_writes(), key=str) == [("sync_write", "goal_position", {1: 10, 2: 20}),
                                                  ("sync_write", "goal_position", {3: 30})]
    bus.calls.clear()
    bus.silent.add(2)
    assert group.read_group("goal_position", [1, 2, 3]) == {1: 10, 3: 30}
    assert sorted(c[1:3] for c in bus.of("sync_read")) == [(116, 4), (596, 4)]


def test_a_failed_write_says_why_in_its_own_result():
    bus = FakeBus({1: XM430, 2: XM430})
    io = ServoIO(bus, table_of(bus), LOG)
    bus.silent.add(2)
    written = io.write_item(2, "led", 1)
    assert not written and written.value is False and written.failure is Failure.NO_REPLY
    assert io.write_item(1, "led", 1).failure is None and io.torque_off(1)
    missing = io.write_item(1, "no_such_item", 1)
    assert not missing and missing.failure is Failure.NO_SUCH_ITEM and missing.why == "ID 1 (XM430-W350) has no no_such_item"


def test_a_group_write_that_fails_is_one_warning_naming_the_ids_and_keeps_no_value(caplog):
    bus = FakeBus({1: XM430, 2: XM430})
    table = table_of(bus)
    group = GroupIO(bus, table, LOG)
    bus.fail_sync_writes = True
    with caplog.at_level(logging.WARNING, logger=LOG.name):
        group.write_group("goal_position", {1: 10, 2: 20}, what="shutdown")
    assert [r.getMessage() for r in caplog.records if r.name == LOG.name] == [
        "shutdown: writing goal_position to IDs [1, 2] failed: sync write @116x4: device lost"]
    assert table.value("goal_position", 1) is None and table.value("goal_position", 2) is None


def test_a_snapshot_reads_nearby_items_in_one_sync_read_and_items_far_apart_in_another():
    bus = FakeBus({1: XM430, 2: XM430, 3: XM430})
    table = table_of(bus)
    group = GroupIO(bus, table, LOG)
    for dxl_id in (1, 2):
        bus.set(dxl_id, "operating_mode", OPERATING_MODES["ex_position"])
        bus.set(dxl_id, "homing_offset", -100 * dxl_id)
        bus.set(dxl_id, "goal_position", 1000 + dxl_id)
        bus.set(dxl_id, "present_position", -5000 - dxl_id)
    bus.silent.add(3)
    items = ["present_position", "operating_mode", "no_such_item", "goal_position", "homing_offset"]
    assert group.read_items(items, [1, 2, 3]) == {
        dxl_id: {"operating_mode": OPERATING_MODES["ex_position"], "homing_offset": -100 * dxl_id,
                 "goal_position": 1000 + dxl_id, "present_position": -5000 - dxl_id} for dxl_id in (1, 2)}
    reads = bus.of("sync_read")
    assert len(reads) == 2 and all(r[3] == (1, 2, 3) for r in reads)  # two spans, each one read of every servo
    assert table.value("goal_position", 1) is None  # a snapshot, not the table's last reads


AX12A = 12


def test_a_protocol1_servos_mode_is_its_angle_limits_and_joint_mode_gets_its_own_limits_back():
    bus = FakeBus({}, protocol1={4: AX12A})
    bus.set(4, "min_position_limit", 100)
    bus.set(4, "max_position_limit", 900)
    io = ServoIO(bus, table_of(bus), LOG)
    assert io.mode(4) == "position"  # limits apart: Joint Mode
    assert io.write_item(4, "operating_mode", OPERATING_MODES["velocity"])
    assert (bus.get(4, "min_position_limit"), bus.get(4, "max_position_limit")) == (0, 0)  # Wheel Mode
    assert io.mode(4) == "velocity"
    assert io.write_item(4, "operating_mode", OPERATING_MODES["position"])
    assert (bus.get(4, "min_position_limit"), bus.get(4, "max_position_limit")) == (100, 900)
    refused = io.write_item(4, "operating_mode", OPERATING_MODES["pwm"])
    assert not refused and refused.why == "ID 4 (AX-12A) has no mode 16"


def test_a_protocol1_servos_hardware_error_is_the_state_bits_of_its_status_error_byte():
    bus = FakeBus({}, protocol1={4: AX12A})
    table = table_of(bus)
    io = ServoIO(bus, table, LOG)
    bus.errors[4] = 0x04 | 0x20  # overheating and overload: the servo's state, in each of its statuses
    assert io.read_item(4, "hardware_error_status") == 0x24 and table.value("hardware_error_status", 4) == 0x24
    bus.errors[4] = 0x04 | 0x08  # and a range error: the bus takes the status as a refusal, no state read
    assert io.read_item(4, "hardware_error_status") is None and table.value("hardware_error_status", 4) == 0x24
    bus.silent.add(4)
    assert io.read_item(4, "hardware_error_status") is None


def test_torque_on_in_current_mode_zeroes_the_goal_first_and_a_failed_one_is_a_warning(caplog):
    bus = FakeBus({1: XM430})
    io = ServoIO(bus, table_of(bus), LOG)
    bus.set(1, "operating_mode", OPERATING_MODES["current"])
    bus.set(1, "goal_current", 200)
    assert io.torque_on(1)
    assert [w[1:] for w in bus.item_writes()] == [("goal_current", (1, 0)), ("torque_enable", (1, 1))]
    bus.silent.add(1)
    with caplog.at_level(logging.WARNING, logger=LOG.name):
        assert not io.torque_on(1)
    (line,) = [r.getMessage() for r in caplog.records]
    assert line.startswith("ID 1 (XM430-W350): torque on failed")
