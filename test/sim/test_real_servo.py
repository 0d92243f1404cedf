"""The virtual bus against the rules real servos follow, driven by the real ``dynamixel_sdk`` only
(no handler code): indirect addressing (also through Sync/Bulk Read and Write), Status Return
Level, Registered Write + Action, the three Factory Reset levels, Control Table Backup, the
baud rate and protocol a servo answers at, and the state file. Expected values are the e-Manual's.
"""

import subprocess
import sys

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS, GroupBulkRead, GroupBulkWrite, GroupSyncRead, GroupSyncWrite
from dynamixel_sdk.protocol2_packet_handler import PKT_ID, PKT_INSTRUCTION, PKT_LENGTH_H, PKT_LENGTH_L, PKT_PARAMETER0

from dynamixel_handler.control_table import known_models, model_by_number
from dynamixel_handler.protocol import servo as p
from dynamixel_handler.sim import VirtualBus

XM430, XL330, PH54, H54_OLD = 1020, 1200, 2020, 54024
# X430/540: Indirect Address 1 at 168, Indirect Data 1 at 224 (e-Manual). X330 firmware v52: 208.
# P: Indirect Address 1 at 168, Data 1 at 634. Old PRO "-R": Address 1 at 49, Data 1 at 634.
X_IA, X_ID, X330_ID, P_IA, P_ID = 168, 224, 208, 168, 634
X_GOAL, X_PRESENT, X_TORQUE, X_LED = 116, 132, 64, 65
P_GOAL, P_TORQUE = 564, 512


def le(value: int, size: int) -> list[int]:
    return list(int(value & ((1 << (8 * size)) - 1)).to_bytes(size, "little"))


def map_indirect(ph, port, dxl_id: int, first_address: int, targets: list[int]) -> None:
    """Point consecutive Indirect Address entries at ``targets`` (one byte each)."""
    for k, target in enumerate(targets):
        assert ph.write2ByteTxRx(port, dxl_id, first_address + 2 * k, target) == (COMM_SUCCESS, 0)


def span(address: int, size: int) -> list[int]:
    return list(range(address, address + size))


def backup(ph, port, dxl_id: int, option: int):
    """Control Table Backup (0x20): option 0x01 store, 0x02 restore, then "CTRL"."""
    tx = [0] * 15
    tx[PKT_ID], tx[PKT_LENGTH_L], tx[PKT_LENGTH_H], tx[PKT_INSTRUCTION] = dxl_id, 8, 0, p.BACKUP
    tx[PKT_PARAMETER0:PKT_PARAMETER0 + 5] = [option, *b"CTRL"]
    _, result, error = ph.txRxPacket(port, tx)
    return result, error


# ============================================================================ indirect addressing
def test_indirect_data_reads_and_writes_the_mapped_registers(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    # data 1-4: Goal Position, 5: LED
    map_indirect(ph, port, 1, X_IA, span(X_GOAL, 4) + [X_LED])
    assert ph.write1ByteTxRx(port, 1, X_TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph.writeTxRx(port, 1, X_ID, 5, le(3000, 4) + [1]) == (COMM_SUCCESS, 0)
    assert bus.servo(1).read("goal_position") == 3000 and bus.servo(1).read("led") == 1
    assert ph.read4ByteTxRx(port, 1, X_ID) == (3000, COMM_SUCCESS, 0)
    # the data bytes follow the register, whoever wrote it
    assert ph.write4ByteTxRx(port, 1, X_GOAL, 1000) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 1, X_ID) == (1000, COMM_SUCCESS, 0)
    # a goal beyond the limits through indirect data: the same Data Limit Error, nothing written
    assert ph.writeTxRx(port, 1, X_ID, 4, le(5000, 4)) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)
    assert bus.servo(1).read("goal_position") == 1000
    # half of the mapped Goal Position: Data Length Error
    assert ph.write2ByteTxRx(port, 1, X_ID, 5) == (COMM_SUCCESS, p.ERR_DATA_LENGTH)


def test_indirect_addresses_need_torque_off_and_a_valid_target(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.read2ByteTxRx(port, 1, X_IA) == (X_ID, COMM_SUCCESS, 0)  # factory: its own data byte
    assert ph.write1ByteTxRx(port, 1, X_TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph.write2ByteTxRx(port, 1, X_IA, X_GOAL) == (COMM_SUCCESS, p.ERR_ACCESS)
    assert ph.write1ByteTxRx(port, 1, X_TORQUE, 0) == (COMM_SUCCESS, 0)
    assert ph.write2ByteTxRx(port, 1, X_IA, 10) == (COMM_SUCCESS, p.ERR_DATA_RANGE)  # EEPROM: 64..661 only
    assert ph.read2ByteTxRx(port, 1, X_IA) == (X_ID, COMM_SUCCESS, 0)
    # unmapped data bytes are plain storage
    assert ph.write1ByteTxRx(port, 1, X_ID + 3, 77) == (COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 1, X_ID + 3) == (77, COMM_SUCCESS, 0)


def test_indirect_data_through_sync_write_and_sync_read(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: XM430, 3: XL330})
    port, ph = make_sdk(bus.path)
    for dxl_id, data in ((1, X_ID), (2, X_ID), (3, X330_ID)):
        map_indirect(ph, port, dxl_id, X_IA, span(X_GOAL, 4) + span(X_PRESENT, 4))
    assert ph.read2ByteTxRx(port, 3, 168) == (X_GOAL, COMM_SUCCESS, 0)
    writer = GroupSyncWrite(port, ph, X_ID, 4)
    for dxl_id in (1, 2):
        assert writer.addParam(dxl_id, le(1500 + dxl_id, 4))
    assert writer.txPacket() == COMM_SUCCESS
    assert ph.write4ByteTxRx(port, 3, X330_ID, 2500) == (COMM_SUCCESS, 0)  # X330 v52: data at 208
    reader = GroupSyncRead(port, ph, X_ID, 8)
    for dxl_id in (1, 2):
        assert reader.addParam(dxl_id)
    assert reader.txRxPacket() == COMM_SUCCESS
    for dxl_id in (1, 2):
        assert reader.getData(dxl_id, X_ID, 4) == 1500 + dxl_id
        assert reader.getData(dxl_id, X_ID + 4, 4) == bus.servo(dxl_id).read("present_position")
    assert bus.servo(3).read("goal_position") == 2500


def test_indirect_data_through_bulk_write_and_bulk_read_on_x_p_and_old_pro(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: PH54, 3: H54_OLD})
    port, ph = make_sdk(bus.path)
    map_indirect(ph, port, 1, X_IA, span(X_GOAL, 4))
    map_indirect(ph, port, 2, P_IA, span(P_GOAL, 4))
    map_indirect(ph, port, 3, 49, span(596, 4))  # old PRO: Goal Position 596
    writer = GroupBulkWrite(port, ph)
    assert writer.addParam(1, X_ID, 4, le(3000, 4))
    assert writer.addParam(2, P_ID, 4, le(-200_000, 4))
    assert writer.addParam(3, 634, 4, le(100_000, 4))
    for dxl_id, torque in ((1, X_TORQUE), (2, P_TORQUE), (3, 562)):
        assert ph.write1ByteTxRx(port, dxl_id, torque, 1) == (COMM_SUCCESS, 0)
    assert writer.txPacket() == COMM_SUCCESS
    reader = GroupBulkRead(port, ph)
    assert reader.addParam(1, X_ID, 4) and reader.addParam(2, P_ID, 4) and reader.addParam(3, 634, 4)
    assert reader.txRxPacket() == COMM_SUCCESS
    assert reader.getData(1, X_ID, 4) == 3000
    assert reader.getData(2, P_ID, 4) == (-200_000) & 0xFFFFFFFF
    assert reader.getData(3, 634, 4) == 100_000
    assert [bus.servo(i).read("goal_position") for i in (1, 2, 3)] == [3000, -200_000, 100_000]


# ============================================================================ status return level
def test_status_return_level_one_answers_reads_only(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 68, 1) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, X_LED, 1)[0] == COMM_RX_TIMEOUT  # no reply to a write...
    assert bus.servo(1).read("led") == 1                                # ...which was done
    assert ph.read1ByteTxRx(port, 1, X_LED) == (1, COMM_SUCCESS, 0)
    assert ph.ping(port, 1)[1] == COMM_SUCCESS


def test_status_return_level_zero_answers_ping_only(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 68, 0) == (COMM_SUCCESS, 0)  # answered at the level it arrived at
    assert ph.read1ByteTxRx(port, 1, X_LED)[1] == COMM_RX_TIMEOUT
    assert ph.ping(port, 1) == (XM430, COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 68, 2)[0] == COMM_RX_TIMEOUT
    assert ph.read1ByteTxRx(port, 1, 68) == (2, COMM_SUCCESS, 0)


def test_status_return_level_out_of_range_is_refused(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 68, 3) == (COMM_SUCCESS, p.ERR_DATA_RANGE)


# ============================================================================ registered write, action
def test_registered_writes_wait_for_action(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: XM430})
    port, ph = make_sdk(bus.path)
    for dxl_id in (1, 2):
        assert ph.write1ByteTxRx(port, dxl_id, X_TORQUE, 1) == (COMM_SUCCESS, 0)
        assert ph.regWriteTxRx(port, dxl_id, X_GOAL, 4, le(1000 * dxl_id, 4)) == (COMM_SUCCESS, 0)
        assert ph.read1ByteTxRx(port, dxl_id, 69) == (1, COMM_SUCCESS, 0)  # Registered Instruction
    assert bus.servo(1).read("goal_position") != 1000
    assert ph.action(port, p.BROADCAST_ID) == COMM_SUCCESS
    assert ph.ping(port, 1)[1] == COMM_SUCCESS
    assert [bus.servo(i).read("goal_position") for i in (1, 2)] == [1000, 2000]
    assert ph.read1ByteTxRx(port, 1, 69) == (0, COMM_SUCCESS, 0)


# ============================================================================ factory reset
@pytest.mark.parametrize("option,expect_id,expect_baud", [(0x01, 7, 1), (0x02, 7, 3), (0xFF, 1, 1)])
def test_factory_reset_levels(make_bus, make_sdk, option, expect_id, expect_baud):
    bus = make_bus({7: XM430})  # at 1 Mbps: Baud Rate 3
    port, ph = make_sdk(bus.path)
    assert ph.write4ByteTxRx(port, 7, 48, 3000) == (COMM_SUCCESS, 0)   # Max Position Limit
    map_indirect(ph, port, 7, X_IA, [X_GOAL])
    assert ph.factoryReset(port, 7, option) == (COMM_SUCCESS, 0)
    servo = bus.servos[expect_id]
    assert (servo.read("baud_rate"), servo.read("max_position_limit")) == (expect_baud, 4095)
    assert servo.read_raw(X_IA, 2) == bytes([X_ID, 0])  # indirect addresses back to their own data


def test_factory_reset_all_is_refused_on_broadcast(make_bus, make_sdk):
    bus = make_bus({7: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.write4ByteTxRx(port, 7, 48, 3000) == (COMM_SUCCESS, 0)
    ph.factoryReset(port, p.BROADCAST_ID, 0xFF)
    assert ph.read4ByteTxRx(port, 7, 48) == (3000, COMM_SUCCESS, 0)


# ============================================================================ control table backup
def test_backup_and_restore_of_the_eeprom_area(make_bus, make_sdk):
    bus = make_bus({1: XL330, 2: PH54, 3: H54_OLD})
    port, ph = make_sdk(bus.path)
    assert backup(ph, port, 1, 0x02) == (COMM_SUCCESS, p.ERR_RESULT_FAIL)  # nothing stored yet
    assert ph.read1ByteTxRx(port, 1, 147) == (0, COMM_SUCCESS, 0)           # Backup Ready
    assert ph.write4ByteTxRx(port, 1, 48, 3000) == (COMM_SUCCESS, 0)
    map_indirect(ph, port, 1, X_IA, [X_GOAL])
    assert backup(ph, port, 1, 0x01) == (COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 1, 147) == (1, COMM_SUCCESS, 0)
    assert ph.write4ByteTxRx(port, 1, 48, 2000) == (COMM_SUCCESS, 0)
    map_indirect(ph, port, 1, X_IA, [X_LED])
    assert ph.write1ByteTxRx(port, 1, X_TORQUE, 1) == (COMM_SUCCESS, 0)
    assert backup(ph, port, 1, 0x02) == (COMM_SUCCESS, p.ERR_ACCESS)       # torque on
    assert ph.write1ByteTxRx(port, 1, X_TORQUE, 0) == (COMM_SUCCESS, 0)
    assert backup(ph, port, 1, 0x02) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 1, 48) == (3000, COMM_SUCCESS, 0)
    assert ph.read2ByteTxRx(port, 1, X_IA) == (X_GOAL, COMM_SUCCESS, 0)
    # a reboot keeps the backup
    assert ph.reboot(port, 1) == (COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 1, 147) == (1, COMM_SUCCESS, 0)
    # P has it (Backup Ready 878); the old PRO firmware does not know the instruction
    assert backup(ph, port, 2, 0x01) == (COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 2, 878) == (1, COMM_SUCCESS, 0)
    assert backup(ph, port, 3, 0x01) == (COMM_SUCCESS, p.ERR_INSTRUCTION)


# ============================================================================ baud rate, protocol
def test_default_servos_answer_only_at_57600(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: PH54}, baudrate=None, wire_timing=True)  # the defaults
    port, ph = make_sdk(bus.path, 1_000_000)
    assert ph.ping(port, 1)[1] == COMM_RX_TIMEOUT
    assert port.setBaudRate(57600)
    assert ph.ping(port, 1) == (XM430, COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 2, 8) == (1, COMM_SUCCESS, 0)   # Baud Rate register: 57600
    assert ph.read1ByteTxRx(port, 2, 9) == (250, COMM_SUCCESS, 0)  # Return Delay Time: 500 us


def test_protocol_1_packets_get_no_reply(make_bus, make_raw):
    bus = make_bus({1: XM430})
    raw = make_raw(bus.path)
    ping_v1 = bytes([0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB])  # Protocol 1.0 PING to ID 1
    assert raw.exchange(ping_v1, 1, timeout=0.2) == b""
    assert raw.exchange(p.build_packet(1, p.PING), 14)[:5] == bytes([0xFF, 0xFF, 0xFD, 0x00, 0x01])


def test_a_servo_set_to_protocol_1_stops_answering_protocol_2(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 13, 1) == (COMM_SUCCESS, 0)  # Protocol Type
    assert ph.ping(port, 1)[1] == COMM_RX_TIMEOUT
    assert bus.servo(1).read("protocol_type") == 1


# ============================================================================ state file
def test_eeprom_survives_a_restart_through_the_state_file(make_bus, make_sdk, tmp_path):
    state = str(tmp_path / "bus.json")
    bus = make_bus({1: XM430, 2: XL330}, state_file=state)
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 7, 5) == (COMM_SUCCESS, 0)        # ID 1 -> 5 (answered as ID 1)
    assert ph.write4ByteTxRx(port, 5, 48, 3000) == (COMM_SUCCESS, 0)   # Max Position Limit
    map_indirect(ph, port, 2, X_IA, [X_GOAL])
    assert backup(ph, port, 2, 0x01) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 5, X_LED, 1) == (COMM_SUCCESS, 0)   # RAM: not kept
    assert bus.eeprom_changed
    bus.save_state()
    assert not bus.eeprom_changed
    with VirtualBus(state_file=state, baudrate=None, wire_timing=False) as again:
        assert sorted(again.servos) == [2, 5]
        five = again.servo(5)
        assert (five.model.number, five.read("max_position_limit"), five.read("led")) == (XM430, 3000, 0)
        assert five.read("baud_rate") == 3  # the 1 Mbps it was at, not the factory 57600
        two = again.servo(2)
        assert two.read_raw(X_IA, 2) == bytes([X_GOAL, 0]) and two.read("backup_ready") == 1


# ============================================================================ data range
@pytest.mark.parametrize("address,size,value", [
    (20, 4, 1_044_480),   # Homing Offset: -1,044,479 .. 1,044,479
    (24, 4, 1024),        # Moving Threshold: 0 .. 1,023
    (84, 2, 16384),       # Position P Gain: 0 .. 16,383
    (108, 4, 32768),      # Profile Acceleration: 0 .. 32,767
    (112, 4, 32768),      # Profile Velocity: 0 .. 32,767
    (11, 1, 2),           # Operating Mode 2 does not exist
    (8, 1, 8),            # Baud Rate 8 (6 Mbps) is P only
])
def test_x_values_out_of_range_get_data_range_error(make_bus, make_sdk, address, size, value):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    before = bus.servo(1).read_raw(address, size)
    write = {1: ph.write1ByteTxRx, 2: ph.write2ByteTxRx, 4: ph.write4ByteTxRx}[size]
    assert write(port, 1, address, value) == (COMM_SUCCESS, p.ERR_DATA_RANGE)
    assert bus.servo(1).read_raw(address, size) == before


# ============================================================================ dual servos
def test_the_two_axes_of_a_2xl430_share_their_baud_rate(make_bus, make_sdk):
    bus = make_bus({1: 1090, 2: 1090, 3: XM430})  # 2XL430-W250: IDs 1 and 2 are one servo
    port, ph = make_sdk(bus.path)
    assert ph.write1ByteTxRx(port, 1, 8, 4) == (COMM_SUCCESS, 0)  # 2 Mbps, answered at 1 Mbps
    assert ph.ping(port, 2)[1] == COMM_RX_TIMEOUT and ph.ping(port, 3)[1] == COMM_SUCCESS
    assert port.setBaudRate(2_000_000)
    assert ph.ping(port, 1) == (1090, COMM_SUCCESS, 0) and ph.ping(port, 2) == (1090, COMM_SUCCESS, 0)
    assert ph.read1ByteTxRx(port, 2, 8) == (4, COMM_SUCCESS, 0)


# ============================================================================ every model
@pytest.mark.parametrize("number", [m.number for m in known_models() if m.indirect])  # XL-320: none
def test_every_model_answers_with_its_number_and_maps_indirect_data(make_bus, make_sdk, number):
    bus = make_bus({1: number})
    port, ph = make_sdk(bus.path)
    model = model_by_number(number)
    assert ph.ping(port, 1) == (number, COMM_SUCCESS, 0)
    assert ph.read2ByteTxRx(port, 1, 0) == (number, COMM_SUCCESS, 0)
    first_address, first_data, _ = bus.servo(1).model.indirect_blocks(bus.servo(1).read("firmware_version"))[0]
    goal = model.item("goal_position").address
    map_indirect(ph, port, 1, first_address, span(goal, 4))
    assert ph.write1ByteTxRx(port, 1, model.item("torque_enable").address, 1) == (COMM_SUCCESS, 0)
    target = model.position_zero_pulse + model.position_max_pulse // 4
    assert ph.write4ByteTxRx(port, 1, first_data, target) == (COMM_SUCCESS, 0)
    assert bus.servo(1).read("goal_position") == target


# ============================================================================ command line
def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dynamixel_handler.sim", *args], capture_output=True,
                          text=True, timeout=30, stdin=subprocess.DEVNULL)


def test_cli_refuses_a_baud_rate_a_model_cannot_use_and_a_broken_state_file(tmp_path):
    out = run_cli("--servo", "1:XM430-W350", "--baudrate", "6000000")
    assert out.returncode == 2 and "XM430-W350 cannot run at 6000000 bps" in out.stderr
    assert "Traceback" not in out.stderr
    broken = tmp_path / "bus.json"
    broken.write_text("{not json")
    out = run_cli("--state", str(broken))
    assert out.returncode == 2 and "Traceback" not in out.stderr and out.stderr.strip()
