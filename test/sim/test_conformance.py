"""Every instruction through the real dynamixel_sdk host classes, against the virtual bus."""

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS, GroupBulkRead, GroupBulkWrite, GroupSyncRead, GroupSyncWrite

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.protocol import servo as p

XM430, XM540, XH540, XL330, PH54, H54_OLD, H54_RA = 1020, 1120, 1100, 1200, 2020, 54024, 54025
ALL = {1: XM430, 2: XM540, 3: XH540, 4: XL330, 5: PH54, 6: H54_OLD, 7: H54_RA}


@pytest.fixture
def bus_sdk(make_bus, make_sdk):
    bus = make_bus(ALL)
    port, ph = make_sdk(bus.path)
    return bus, port, ph


def settle(port, ph) -> None:
    """Round-trip once so the bus has executed every write-only packet sent before."""
    assert ph.ping(port, 1)[1] == COMM_SUCCESS


def addr(model_number: int, name: str) -> int:
    return model_by_number(model_number).item(name).address


@pytest.mark.parametrize("sid,number", sorted(ALL.items()))
def test_ping_reports_model_number(bus_sdk, sid, number):
    bus, port, ph = bus_sdk
    assert ph.ping(port, sid) == (number, COMM_SUCCESS, 0)


def test_unknown_id_is_silent(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.ping(port, 42)[1] == COMM_RX_TIMEOUT


def test_broadcast_ping_finds_every_servo(bus_sdk):
    bus, port, ph = bus_sdk
    found, result = ph.broadcastPing(port)
    assert result == COMM_SUCCESS
    assert {sid: info[0] for sid, info in found.items()} == ALL
    assert found[1][1] == 48 and found[5][1] >= 12  # firmware with Fast Sync Read support


@pytest.mark.parametrize("sid,number", sorted(ALL.items()))
def test_write_then_read_goal_position_at_model_address(bus_sdk, sid, number):
    bus, port, ph = bus_sdk
    goal = addr(number, "goal_position")
    assert ph.write1ByteTxRx(port, sid, addr(number, "torque_enable"), 1) == (COMM_SUCCESS, 0)
    assert ph.write4ByteTxRx(port, sid, goal, 1000) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, sid, goal) == (1000, COMM_SUCCESS, 0)
    assert bus.servo(sid).read("goal_position") == 1000


def test_read_model_number_and_limits(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.read2ByteTxRx(port, 4, 0) == (XL330, COMM_SUCCESS, 0)
    # e-Manual p/ph54-200-s500-r: Max Position Limit initial value 501,433 (range +-501,923)
    assert ph.read4ByteTxRx(port, 5, addr(PH54, "max_position_limit")) == (501433, COMM_SUCCESS, 0)


def test_write_errors(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (COMM_SUCCESS, 0)
    # EEPROM while torque is on: access error, nothing written
    assert ph.write4ByteTxRx(port, 1, 20, 100) == (COMM_SUCCESS, p.ERR_ACCESS)
    assert bus.servo(1).read("homing_offset") == 0
    # beyond the position limits in position mode: data limit error, goal unchanged
    before = bus.servo(1).read("goal_position")
    assert ph.write4ByteTxRx(port, 1, 116, 5000) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)
    assert bus.servo(1).read("goal_position") == before
    # read-only item
    assert ph.write4ByteTxRx(port, 1, 132, 5) == (COMM_SUCCESS, p.ERR_ACCESS)
    # half of a 4-byte item
    assert ph.write2ByteTxRx(port, 1, 116, 5) == (COMM_SUCCESS, p.ERR_DATA_LENGTH)
    # invalid operating mode value (torque off first)
    assert ph.write1ByteTxRx(port, 1, 64, 0) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 11, 2) == (COMM_SUCCESS, p.ERR_DATA_RANGE)
    # goal velocity / current / pwm above their limits
    assert ph.write4ByteTxRx(port, 1, 104, 100000) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)
    assert ph.write2ByteTxRx(port, 1, 102, 2000) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)
    assert ph.write2ByteTxRx(port, 1, 100, 900) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)


def test_reg_write_and_broadcast_action(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.regWriteTxRx(port, 1, 65, 1, [1]) == (COMM_SUCCESS, 0)
    assert ph.regWriteTxRx(port, 2, 65, 1, [1]) == (COMM_SUCCESS, 0)
    assert bus.servo(1).read("led") == 0
    # Broadcast: the SDK's unicast action() leaves the servo's reply unread (tested raw elsewhere).
    assert ph.action(port, p.BROADCAST_ID) == COMM_SUCCESS
    settle(port, ph)
    assert bus.servo(1).read("led") == 1 and bus.servo(2).read("led") == 1


def test_reboot_resets_ram_and_keeps_eeprom(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.write4ByteTxRx(port, 1, 20, 123) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 65, 1) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (COMM_SUCCESS, 0)
    assert ph.reboot(port, 1) == (COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 1, 64) == (0, COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 1, 65) == (0, COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 1, 20) == (123, COMM_SUCCESS, 0)


def test_factory_reset_keeps_id_and_baud(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.write4ByteTxRx(port, 2, 20, 55) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 2, 8, 3) == (COMM_SUCCESS, 0)
    assert ph.factoryReset(port, 2, 0x02) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 2, 20) == (0, COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 2, 8) == (3, COMM_SUCCESS, 0)


def test_factory_reset_all_moves_to_id_1_at_57600(make_bus, make_sdk):
    bus = make_bus({9: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.factoryReset(port, 9, 0xFF) == (COMM_SUCCESS, 0)
    assert ph.ping(port, 1)[1] == COMM_RX_TIMEOUT  # the servo now listens at 57600 only
    assert port.setBaudRate(57600)
    assert ph.ping(port, 1)[1:] == (COMM_SUCCESS, 0)
    assert ph.ping(port, 9)[1] == COMM_RX_TIMEOUT


def test_clear_multi_turn(bus_sdk):
    bus, port, ph = bus_sdk
    servo = bus.servo(1)
    servo.write("operating_mode", 4)
    servo._motor.p = 3 * 4096 + 100.0  # three turns away, at rest
    assert ph.read4ByteTxRx(port, 1, 132) == (3 * 4096 + 100, COMM_SUCCESS, 0)
    assert ph.clearMultiTurn(port, 1) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 1, 132) == (100, COMM_SUCCESS, 0)


def test_sync_read_and_fast_sync_read(bus_sdk):
    bus, port, ph = bus_sdk
    values = {1: 111, 2: 222, 3: 333, 4: 444}
    for sid, v in values.items():
        bus.servo(sid).pin("present_position", v)
    group = GroupSyncRead(port, ph, 132, 4)
    for sid in values:
        assert group.addParam(sid)
    assert group.txRxPacket() == COMM_SUCCESS
    assert {sid: group.getData(sid, 132, 4) for sid in values} == values
    assert group.fastSyncRead() == COMM_SUCCESS
    assert {sid: group.getData(sid, 132, 4) for sid in values} == values


def test_fast_sync_read_stops_at_a_servo_without_support(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: XM430})
    bus.servo(2).write("firmware_version", 44)  # X430 needs firmware 45 for Fast Sync Read
    port, ph = make_sdk(bus.path)
    group = GroupSyncRead(port, ph, 132, 4)
    group.addParam(1)
    group.addParam(2)
    assert group.fastSyncRead() != COMM_SUCCESS
    assert group.txRxPacket() == COMM_SUCCESS


def test_sync_write(bus_sdk):
    bus, port, ph = bus_sdk
    group = GroupSyncWrite(port, ph, 65, 1)
    for sid in (1, 2, 3):
        group.addParam(sid, [1])
    assert group.txPacket() == COMM_SUCCESS
    settle(port, ph)
    assert [bus.servo(sid).read("led") for sid in (1, 2, 3, 4)] == [1, 1, 1, 0]


def test_bulk_read_across_series(bus_sdk):
    bus, port, ph = bus_sdk
    bus.servo(1).pin("present_position", 1234)
    bus.servo(5).pin("present_position", -400000)
    bus.servo(6).pin("present_position", 250000)
    group = GroupBulkRead(port, ph)
    group.addParam(1, 132, 4)
    group.addParam(5, addr(PH54, "present_position"), 4)
    group.addParam(6, addr(H54_OLD, "present_position"), 4)
    assert group.txRxPacket() == COMM_SUCCESS
    assert group.getData(1, 132, 4) == 1234
    assert group.getData(5, 580, 4) == (-400000) & 0xFFFFFFFF
    assert group.getData(6, 611, 4) == 250000


def test_fast_bulk_read(bus_sdk):
    bus, port, ph = bus_sdk
    bus.servo(1).pin("present_position", 2100)
    bus.servo(5).pin("present_velocity", 77)
    group = GroupBulkRead(port, ph)
    # The SDK's fastBulkReadRx looks IDs up by value in its parameter bytes; IDs and addresses
    # are chosen so no address byte equals an ID.
    group.addParam(1, 132, 4)
    group.addParam(5, 576, 4)
    assert group.fastBulkRead() == COMM_SUCCESS
    assert group.getData(1, 132, 4) == 2100
    assert group.getData(5, 576, 4) == 77


def test_bulk_write_across_series(bus_sdk):
    bus, port, ph = bus_sdk
    group = GroupBulkWrite(port, ph)
    group.addParam(1, 65, 1, [1])
    group.addParam(5, addr(PH54, "led_red"), 1, [200])
    group.addParam(6, addr(H54_OLD, "led_green"), 1, [100])
    assert group.txPacket() == COMM_SUCCESS
    settle(port, ph)
    assert bus.servo(1).read("led") == 1
    assert bus.servo(5).read("led_red") == 200
    assert bus.servo(6).read("led_green") == 100


def test_status_return_level(bus_sdk):
    bus, port, ph = bus_sdk
    assert ph.write1ByteTxRx(port, 1, 68, 1) == (COMM_SUCCESS, 0)  # answered at the level it arrived at
    assert ph.write1ByteTxRx(port, 1, 65, 1)[0] == COMM_RX_TIMEOUT  # writes no longer answered
    assert ph.read1ByteTxRx(port, 1, 65) == (1, COMM_SUCCESS, 0)
    assert ph.write1ByteTxOnly(port, 1, 68, 0) == COMM_SUCCESS
    assert ph.read1ByteTxRx(port, 1, 65)[1] == COMM_RX_TIMEOUT
    assert ph.ping(port, 1)[1] == COMM_SUCCESS  # ping always answers


def test_status_packets_are_byte_stuffed(bus_sdk, make_raw):
    bus, port, ph = bus_sdk
    bus.servo(1).pin("present_position", 0x00FDFFFF)  # bytes FF FF FD 00
    assert ph.read4ByteTxRx(port, 1, 132) == (0x00FDFFFF, COMM_SUCCESS, 0)
    port.closePort()
    raw = make_raw(bus.path)
    reply = raw.exchange(p.build_packet(1, p.READ, bytes([132, 0, 4, 0])), 16)
    assert reply == bytes.fromhex("FF FF FD 00 01 09 00 55 00 FF FF FD FD 00") + reply[-2:]
    assert p.crc16(reply[:-2]) == reply[-2] | reply[-1] << 8


def test_instruction_byte_stuffing_is_removed(make_bus, make_raw):
    # The SDK 4.1.0 does not stuff what it sends, so the stuffed instruction is built here.
    bus = make_bus({1: XM430})
    raw = make_raw(bus.path)
    body = bytes([100, 0]) + bytes.fromhex("FF FF FD 00")  # goal_pwm = -1, goal_current = 253
    packet = p.build_packet(1, p.WRITE, body)
    assert b"\xff\xff\xfd\xfd" in packet
    assert raw.exchange(packet, 11) == p.build_status(1, 0)
    assert bus.servo(1).read("goal_pwm") == -1
    assert bus.servo(1).read("goal_current") == 253
