"""The bus of the core's unit tests (test/support/fake_bus.py) is the real ``DynamixelBus`` over a
line in memory (test/support/memory_line.py): each instruction, in either protocol, reaches the line
as one call tuple and is answered from the servos' register images; its switches act as the wire
and the serial port do (a silent servo, old firmware, a device gone)."""
from __future__ import annotations

import pytest

from dynamixel_handler.bus import BusError, DynamixelBus, Failure
from dynamixel_handler.bus.ops import BulkRead, BulkWrite, ErrorByte, Ping, Read, Reboot, SyncRead, Write

from support.fake_bus import XM430, FakeBus

AX12A, MX28 = 12, 29


def le(value: int, size: int = 4) -> bytes:
    return value.to_bytes(size, "little", signed=True)


def test_it_is_the_real_bus_and_each_protocol_2_instruction_is_one_call_answered_from_the_image():
    bus = FakeBus({1: XM430, 2: XM430})
    assert isinstance(bus, DynamixelBus) and bus.line.effective_latency_ms == 1.0 and bus.line.tx_ms_per_byte == 0
    bus.set(2, "present_position", -7)
    assert bus.execute(Ping(1, protocol=2)).value == XM430
    assert bus.execute(Write(1, 116, le(16), protocol=2)) and bus.get(1, "goal_position") == 16
    assert bus.execute(Read(1, 116, 4, protocol=2)).value == le(16)
    assert bus.execute(Reboot(2, protocol=2))
    for fast in (False, True):
        assert bus.execute(SyncRead(132, 4, (1, 2), fast, protocol=2)).value == {1: le(0), 2: le(-7)}
    assert bus.execute(bus.prepare_sync_write(116, 4, {1: le(1), 2: le(2)}, protocol=2))
    assert bus.execute(BulkRead({1: (116, 4), 2: (132, 4)}, protocol=2)).value == {1: le(1), 2: le(-7)}
    assert bus.execute(BulkWrite({2: (65, b"\x01")})) and bus.get(2, "led") == 1
    assert bus.calls == [("ping", 1), ("write", 1, 116, le(16)), ("read", 1, 116, 4), ("reboot", 2),
                         ("sync_read", 132, 4, (1, 2), False), ("sync_read", 132, 4, (1, 2), True),
                         ("sync_write", 116, 4, {1: le(1), 2: le(2)}),
                         ("bulk_read", {1: (116, 4), 2: (132, 4)}, False), ("bulk_write", {2: (65, b"\x01")})]
    assert bus.item_writes() == [("write", "goal_position", (1, 16)), ("sync_write", "goal_position", {1: 1, 2: 2})]
    assert bus.stats.transactions == 9 and bus.stats.retries == 0


def test_a_protocol_1_servo_hears_its_own_protocol_only_and_its_group_reads_are_what_the_bus_sends():
    bus = FakeBus({1: XM430}, protocol1={4: AX12A, 5: MX28})
    bus.set(4, "present_position", 300)
    bus.set(5, "present_position", 700)
    assert bus.execute(Ping(4, protocol=1)).value == AX12A  # a ping, then its model number read at 0
    assert bus.execute(Ping(4, protocol=2)).value is None and bus.execute(Ping(1, protocol=1)).value is None
    assert bus.execute(SyncRead(36, 2, (4, 5), protocol=1)).value == {4: le(300, 2), 5: le(700, 2)}  # one read each
    assert bus.execute(SyncRead(36, 2, (5,), True, protocol=1)).value == {5: le(700, 2)}  # MX: one Bulk Read
    assert bus.execute(bus.prepare_sync_write(30, 2, {4: le(10, 2), 5: le(20, 2)}, protocol=1))
    assert (bus.get(4, "goal_position"), bus.get(5, "goal_position")) == (10, 20)
    assert bus.calls == [("ping1", 4), ("read", 4, 0, 2), ("ping", 4), ("ping1", 1),
                         ("read", 4, 36, 2), ("read", 5, 36, 2), ("bulk_read", {5: (36, 2)}, False),
                         ("sync_write", 30, 2, {4: le(10, 2), 5: le(20, 2)})]


def test_silent_servos_old_firmware_and_status_errors_answer_as_on_the_wire():
    bus = FakeBus({1: XM430, 2: XM430, 3: XM430}, protocol1={4: AX12A})
    bus.silent.add(2)
    read = bus.execute(Read(2, 132, 4, protocol=2))
    assert read.value is None and read.failure is Failure.NO_REPLY and bus.of("read") == [("read", 2, 132, 4)]
    assert set(bus.execute(SyncRead(132, 4, (1, 2, 3), protocol=2)).value) == {1, 3}
    bus.silent.clear()
    bus.no_fast.add(2)
    assert set(bus.execute(SyncRead(132, 4, (1, 2, 3), True, protocol=2)).value) == {1}  # the chain stops at ID 2
    assert set(bus.execute(SyncRead(132, 4, (1, 2, 3), protocol=2)).value) == {1, 2, 3}
    bus.errors[4] = 0x20  # overload
    assert bus.execute(ErrorByte(4, protocol=1)).value == 0x20


def test_a_scan_is_noted_before_its_pings():
    bus = FakeBus({1: XM430, 3: XM430})
    assert bus.scan(range(1, 7)) == {1: XM430, 3: XM430} and bus.calls == [("scan", (1, 2, 3, 4, 5, 6)), ("ping", 254)]
    bus.calls.clear()
    assert bus.scan([3, 4]) == {3: XM430} and bus.calls == [("scan", (3, 4)), ("ping", 3), ("ping", 4)]


def test_a_failing_sync_write_is_a_device_gone_until_it_can_be_reopened():
    bus = FakeBus({1: XM430})
    bus.fail_sync_writes = True
    sent = bus.execute(bus.prepare_sync_write(116, 4, {1: le(5)}, protocol=2))
    assert not sent and sent.failure is Failure.DEVICE_LOST and not bus.is_open and bus.stats.disconnects == 1
    assert bus.of("sync_write") == [("sync_write", 116, 4, {1: le(5)})] and bus.get(1, "goal_position") == 0
    bus.can_reopen = False
    with pytest.raises(BusError):
        bus.reopen()
    bus.can_reopen, bus.fail_sync_writes = True, False
    bus.reopen()
    assert bus.is_open and bus.execute(bus.prepare_sync_write(116, 4, {1: le(5)}, protocol=2))
    assert bus.get(1, "goal_position") == 5
    bus.is_open = False  # the device gone: nothing more reaches the line
    bus.calls.clear()
    assert bus.execute(Ping(1, protocol=2)).failure is Failure.DEVICE_LOST and bus.calls == []
    bus.is_open = True
    assert bus.execute(Ping(1, protocol=2)).value == XM430
