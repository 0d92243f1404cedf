"""BusWithDummies: dummies answer in-process with the value and why not, like the wire's calls; a
call for a real servo while the wire is closed fails at once and says so."""
from __future__ import annotations

from dynamixel_handler.bus import DynamixelBus, dummy_ids
from dynamixel_handler.dummy import BusWithDummies, make_dummies

TORQUE, OPERATING_MODE, GOAL_POSITION, LED = 64, 11, 116, 65


def mixed() -> BusWithDummies:
    return BusWithDummies(DynamixelBus("/dev/null-not-opened"), make_dummies([7, 9], "X"))


def test_a_dummy_write_and_read_back():
    bus = mixed()
    assert bus.write_result(9, LED, b"\x01").value is True
    result = bus.read_result(9, LED, 1)
    assert result.value == b"\x01" and result.failure == ""


def test_a_write_a_dummy_refuses_is_false_with_the_servo_s_error():
    bus = mixed()
    assert bus.write(9, TORQUE, b"\x01")
    refused = bus.write_result(9, OPERATING_MODE, b"\x01")  # EEPROM with torque on
    assert refused.value is False and refused.failure.startswith("write ID 9: ")
    assert "access" in refused.failure.lower()


def test_a_real_servo_behind_a_closed_wire_fails_at_once_and_says_so():
    bus = mixed()
    result = bus.read_result(1, GOAL_POSITION, 4)
    assert result.value is None and result.failure == "read ID 1 @116x4: port closed or device lost"
    assert bus.write_result(1, LED, b"\x01").value is False
    assert bus.ping_result(1).value is None and bus.reboot(1) is False


def test_a_sync_write_reaches_the_dummies_even_when_the_wire_is_closed():
    bus = mixed()
    result = bus.sync_write_result(LED, 1, {7: b"\x01", 9: b"\x01", 1: b"\x01"})
    assert result.value is False and "port closed" in result.failure  # ID 1's part could not go out
    assert bus.read(7, LED, 1) == b"\x01" and bus.read(9, LED, 1) == b"\x01"
    assert bus.sync_write_result(LED, 1, {7: b"\x00"}).value is True  # dummies only: nothing to send


def test_the_dummy_ids_of_a_bus():
    assert dummy_ids(mixed()) == [7, 9]
    assert dummy_ids(DynamixelBus("/dev/null-not-opened")) == []
