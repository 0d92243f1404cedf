"""BusWithDummies: dummies answer in-process with the value and why not, like the wire's calls; a
call for a real servo while the wire is closed fails at once and says so."""
from __future__ import annotations

import time

from dynamixel_handler.bus import DynamixelBus, dummy_ids
from dynamixel_handler.bus.ops import Ping, Read, Reboot, Write
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.dummy import BusWithDummies, make_dummies

TORQUE, OPERATING_MODE, GOAL_POSITION, LED = 64, 11, 116, 65


def mixed() -> BusWithDummies:
    return BusWithDummies(DynamixelBus("/dev/null-not-opened"), make_dummies([7, 9], "X"))


def test_a_dummy_write_and_read_back():
    bus = mixed()
    assert bus.execute(Write(9, LED, b"\x01", protocol=2)).value is True
    result = bus.execute(Read(9, LED, 1, protocol=2))
    assert result.value == b"\x01" and result.failure is None


def test_a_write_a_dummy_refuses_is_false_with_the_servo_s_error():
    bus = mixed()
    assert bus.execute(Write(9, TORQUE, b"\x01", protocol=2)).value
    refused = bus.execute(Write(9, OPERATING_MODE, b"\x01", protocol=2))  # EEPROM with torque on
    assert refused.value is False and refused.why.startswith("write ID 9: ")
    assert refused.failure is Failure.REFUSED and "access" in refused.why.lower()


def test_a_real_servo_behind_a_closed_wire_fails_at_once_and_says_so():
    bus = mixed()
    result = bus.execute(Read(1, GOAL_POSITION, 4, protocol=2))
    assert result.value is None and result.why == "read ID 1 @116x4: port closed or device lost"
    assert bus.execute(Write(1, LED, b"\x01", protocol=2)).value is False
    assert bus.execute(Ping(1, protocol=2)).value is None and bus.execute(Reboot(1, protocol=2)).value is False


def test_a_sync_write_reaches_the_dummies_even_when_the_wire_is_closed():
    bus = mixed()
    result = bus.execute(bus.prepare_sync_write(LED, 1, {7: b"\x01", 9: b"\x01", 1: b"\x01"}, protocol=2))
    assert result.value is False and "port closed" in result.why  # ID 1's part could not go out
    assert bus.execute(Read(7, LED, 1, protocol=2)).value == b"\x01" and bus.execute(Read(9, LED, 1, protocol=2)).value == b"\x01"
    assert bus.execute(bus.prepare_sync_write(LED, 1, {7: b"\x00"}, protocol=2)).value is True  # dummies only: nothing to send


def test_the_dummy_ids_of_a_bus():
    assert dummy_ids(mixed()) == [7, 9]
    assert dummy_ids(DynamixelBus("/dev/null-not-opened")) == []


def test_a_bulk_read_and_write_of_dummies_are_answered_in_process_while_the_wire_is_closed():
    from dynamixel_handler.bus.ops import BulkRead, BulkWrite
    bus = mixed()
    assert bus.execute(BulkWrite({7: (LED, b"\x01"), 9: (GOAL_POSITION, (1000).to_bytes(4, "little"))})).value is True
    got = bus.execute(BulkRead({7: (LED, 1), 9: (GOAL_POSITION, 4)}, protocol=2))
    assert got.value == {7: b"\x01", 9: (1000).to_bytes(4, "little")} and got.ok
    mixed_read = bus.execute(BulkRead({7: (LED, 1), 1: (LED, 1)}, protocol=2))  # ID 1 is behind the closed wire
    assert mixed_read.value == {7: b"\x01"}


def test_a_dummy_reboots_as_a_servo_does_its_ram_back_to_its_initial_values():
    bus = mixed()
    assert bus.execute(Write(7, LED, b"\x01", protocol=2)).value is True
    assert bus.execute(Reboot(7, protocol=2)).value is True
    deadline = time.monotonic() + 5.0
    while (back := bus.execute(Read(7, LED, 1, protocol=2))).value is None and time.monotonic() < deadline:
        pass  # a servo answers nothing while it boots
    assert back.value == b"\x00"
