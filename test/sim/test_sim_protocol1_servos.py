"""The Protocol 1.0 servos of the virtual bus (AX, RX, DX, EX, MX with the 1.0 firmware), as a host
sees them through the real dynamixel_sdk ``PacketHandler(1.0)`` over the pty: every model, status
return levels, return delay, reg write / action, reset, sync write, bulk read (MX and EX), the
status error bits, Joint, Wheel, multi-turn and torque modes, present speed / load / current, wire
timing and a Protocol 2.0 servo on the same ID.

Three dynamixel_sdk 4.1.0 defects are tested around (docs/compatibility.md): ``GroupBulkRead``
raises TypeError on Protocol 1.0 (the bulk read is sent by hand here), ``ping()`` fails on a servo at
Status Return Level 0 (it reads the model number after the ping), and ``read1ByteTxRx`` on a bare
error status returns the checksum byte as the value.
"""

from __future__ import annotations

import time

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS, GroupBulkRead, GroupSyncWrite, PacketHandler

from dynamixel_handler.control_table import protocol1_models
from dynamixel_handler.sim.protocol1 import build_instruction1, build_status1, checksum

AX12A, AX18A, MX28, MX64, EX106, XM430 = 12, 18, 29, 310, 107, 1020
TORQUE, GOAL, SPEED, TORQUE_LIMIT, PRESENT, PRESENT_SPEED, LOAD = 24, 30, 32, 34, 36, 38, 40
CW_LIMIT, CCW_LIMIT, STATUS_LEVEL, RETURN_DELAY = 6, 8, 16, 5


@pytest.fixture
def sdk1(make_sdk):
    """Factory: sdk1(path, bps) -> (port, PacketHandler(1.0))."""
    def factory(path: str, bps: int = 1_000_000):
        port, _ = make_sdk(path, bps)
        return port, PacketHandler(1.0)
    return factory


def test_every_protocol1_model_answers_with_its_number_and_factory_table(make_bus, sdk1):
    models = protocol1_models()
    bus = make_bus({k + 1: m.number for k, m in enumerate(models)})
    port, ph1 = sdk1(bus.path)
    for k, model in enumerate(models):
        sid = k + 1
        assert ph1.ping(port, sid) == (model.number, COMM_SUCCESS, 0), model.name
        ccw, result, error = ph1.read2ByteTxRx(port, sid, CCW_LIMIT)
        assert (ccw, result, error) == (model.factory["max_position_limit"], COMM_SUCCESS, 0), model.name
        assert ph1.read1ByteTxRx(port, sid, 11)[0] == model.factory["temperature_limit"], model.name
        assert ph1.read2ByteTxRx(port, sid, TORQUE_LIMIT)[0] == model.factory["pwm_limit"], model.name  # := Max Torque
        assert ph1.read2ByteTxRx(port, sid, PRESENT)[0] == model.position_zero_pulse, model.name


def test_status_return_levels_and_what_the_sdk_makes_of_level_0(make_bus, sdk1, make_raw):
    bus = make_bus({1: AX12A, 2: AX12A})
    port, ph1 = sdk1(bus.path)
    assert ph1.write1ByteTxRx(port, 1, STATUS_LEVEL, 1) == (COMM_SUCCESS, 0)  # answered as at level 2
    assert ph1.read1ByteTxRx(port, 1, STATUS_LEVEL)[:2] == (1, COMM_SUCCESS)    # level 1: READ answered
    assert ph1.write1ByteTxRx(port, 1, 25, 1)[0] == COMM_RX_TIMEOUT             # ... WRITE not
    assert bus.servos_at(1)[0].read("led") == 1                                 # (yet done)
    assert ph1.write1ByteTxRx(port, 2, STATUS_LEVEL, 0) == (COMM_SUCCESS, 0)
    assert ph1.read1ByteTxRx(port, 2, STATUS_LEVEL)[1] == COMM_RX_TIMEOUT       # level 0: READ not answered
    assert ph1.ping(port, 2)[1] == COMM_RX_TIMEOUT  # SDK: its ping reads the model number, unanswered
    port.closePort()
    raw = make_raw(bus.path)
    assert raw.exchange(build_instruction1(2, 0x01), 6) == build_status1(2, 0)  # the PING itself is answered


def _ping_times(port, ph1, ids: tuple[int, ...], n: int = 30) -> dict[int, list[float]]:
    """``n`` answered pings of each of ``ids``, taken in turn (so a load spike falls on all alike)."""
    times: dict[int, list[float]] = {sid: [] for sid in ids}
    for _ in range(3 * n):
        for sid in ids:
            start = time.perf_counter()
            if ph1.ping(port, sid)[1] == COMM_SUCCESS:
                times[sid].append(time.perf_counter() - start)
        if all(len(t) >= n for t in times.values()):
            return times
    raise AssertionError(f"only {[len(t) for t in times.values()]} of {3 * n} pings answered")


def test_replies_wait_for_return_delay_time_and_the_wire(make_bus, sdk1):
    """A ping of the SDK is PING + READ of 2 bytes: (6 + 6) + (8 + 8) bytes; at 57600 bps that is
    4.9 ms of wire, plus 2 x 500 us of Return Delay Time (250, factory). Lower bounds only: a loaded
    machine can only add time; the fastest of each servo's pings are compared, over up to three
    rounds (a host overloaded fourfold has held every one of 30 pings of one servo back 0.3 ms)."""
    bus = make_bus({1: AX12A, 2: AX12A}, baudrate=57600, wire_timing=True)
    port, ph1 = sdk1(bus.path, 57600)
    assert ph1.read1ByteTxRx(port, 1, RETURN_DELAY)[:2] == (250, COMM_SUCCESS)
    assert ph1.write1ByteTxRx(port, 2, RETURN_DELAY, 0) == (COMM_SUCCESS, 0)
    wire = 28 * 10 / 57600
    gaps = []
    for _ in range(3):
        times = _ping_times(port, ph1, (1, 2))
        slow, fast = min(times[1]), min(times[2])
        assert slow >= wire + 2 * 500e-6 and fast >= wire
        gaps.append(slow - fast)
        if gaps[-1] >= 700e-6:
            break
    assert max(gaps) >= 700e-6, f"Return Delay Time 250 against 0 added {[round(g * 1e6) for g in gaps]} us"


def test_reg_write_waits_for_action_and_action_alone_is_an_instruction_error(make_bus, sdk1, manual_clock):
    bus = make_bus({1: AX12A, 2: AX12A}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    for sid in (1, 2):
        assert ph1.write1ByteTxRx(port, sid, TORQUE, 1) == (COMM_SUCCESS, 0)
        assert ph1.regWriteTxRx(port, sid, GOAL, 2, [0x00, 0x03]) == (COMM_SUCCESS, 0)  # 768, registered
        assert ph1.read1ByteTxRx(port, sid, 44)[:2] == (1, COMM_SUCCESS)                  # Registered
    manual_clock.advance(2.0)
    assert ph1.read2ByteTxRx(port, 1, GOAL)[0] == 512 and ph1.read2ByteTxRx(port, 1, PRESENT)[0] == 512
    assert ph1.action(port, 254) == COMM_SUCCESS        # broadcast: both start, nobody answers
    assert ph1.read2ByteTxRx(port, 2, GOAL)[0] == 768   # (a read after it: the action has been done)
    manual_clock.advance(2.0)
    for sid in (1, 2):
        assert ph1.read2ByteTxRx(port, sid, PRESENT)[0] == 768
        assert ph1.read1ByteTxRx(port, sid, 44)[0] == 0
    assert ph1.txRxPacket(port, list(build_instruction1(1, 0x05)))[2] == 0x40   # nothing registered


def test_reset_brings_back_the_factory_table(make_bus, sdk1):
    bus = make_bus({5: AX12A})
    port, ph1 = sdk1(bus.path)
    assert ph1.write2ByteTxRx(port, 5, CCW_LIMIT, 800) == (COMM_SUCCESS, 0)
    assert ph1.factoryReset(port, 5) == (COMM_SUCCESS, 0)   # answered by ID 5, then ID 1
    assert ph1.ping(port, 5)[1] == COMM_RX_TIMEOUT
    assert ph1.read2ByteTxRx(port, 1, CCW_LIMIT)[:2] == (1023, COMM_SUCCESS)
    assert bus.servos_at(1)[0].eeprom_changed


def test_sync_write_moves_every_listed_servo(make_bus, sdk1, manual_clock):
    bus = make_bus({1: AX12A, 2: AX18A, 3: AX12A}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    torque = GroupSyncWrite(port, ph1, TORQUE, 1)
    goals = GroupSyncWrite(port, ph1, GOAL, 4)   # Goal Position and Moving Speed in one span
    for sid, goal in ((1, 300), (2, 700)):
        torque.addParam(sid, [1])
        goals.addParam(sid, list(goal.to_bytes(2, "little")) + [100, 0])
    assert torque.txPacket() == COMM_SUCCESS and goals.txPacket() == COMM_SUCCESS
    assert ph1.read2ByteTxRx(port, 1, GOAL)[:2] == (300, COMM_SUCCESS)  # no reply to a sync write: read after it
    manual_clock.advance(3.0)
    assert [ph1.read2ByteTxRx(port, sid, PRESENT)[0] for sid in (1, 2, 3)] == [300, 700, 512]
    assert ph1.read2ByteTxRx(port, 2, SPEED)[0] == 100


def _bulk_read(entries: list[tuple[int, int, int]]) -> bytes:
    """BULK READ (0x92) to broadcast: 0x00, then (length, ID, address) per servo."""
    params = bytes([0x00]) + b"".join(bytes(e) for e in entries)
    return build_instruction1(254, 0x92, params)


def test_bulk_read_on_mx_and_ex_each_after_the_one_before(make_bus, sdk1, make_raw):
    bus = make_bus({1: MX28, 2: EX106, 3: MX64, 4: AX12A})
    port, ph1 = sdk1(bus.path)
    with pytest.raises(TypeError):  # dynamixel_sdk 4.1.0 on Protocol 1.0: bulkReadTx gets one argument too many
        group = GroupBulkRead(port, ph1)
        group.addParam(1, PRESENT, 2)
        group.txRxPacket()
    port.closePort()
    raw = make_raw(bus.path)
    # MX-28: 2 bytes at 36 (Present Position 2048); EX-106+: 1 byte at 3 (ID); MX-64: 2 at 8 (4095)
    request = _bulk_read([(2, 1, PRESENT), (1, 2, 3), (2, 3, CCW_LIMIT)])
    expected = build_status1(1, 0, bytes([0x00, 0x08])) + build_status1(2, 0, bytes([2])) + \
        build_status1(3, 0, bytes([0xFF, 0x0F]))
    assert raw.exchange(request, len(expected)) == expected
    # an AX does not know Bulk Read: it stays silent, and the servo listed after it waits for it in vain
    request = _bulk_read([(2, 1, PRESENT), (1, 4, 3), (1, 2, 3)])
    assert raw.exchange(request, 20, timeout=0.3) == build_status1(1, 0, bytes([0x00, 0x08]))
    # an ID listed twice answers once
    request = _bulk_read([(1, 2, 3), (1, 2, 4)])
    assert raw.exchange(request, 20, timeout=0.3) == build_status1(2, 0, bytes([2]))


def test_error_bits_of_the_status(make_bus, sdk1, make_raw, manual_clock):
    bus = make_bus({1: AX12A}, clock=manual_clock)
    ax = bus.servos_at(1)[0]
    port, ph1 = sdk1(bus.path)
    assert ph1.write2ByteTxRx(port, 1, CCW_LIMIT, 800) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, GOAL, 900) == (COMM_SUCCESS, 0x02)   # beyond CCW Angle Limit
    assert ph1.write1ByteTxRx(port, 1, 3, 254) == (COMM_SUCCESS, 0x08)      # ID 254: range
    assert ph1.write1ByteTxRx(port, 1, 4, 0) == (COMM_SUCCESS, 0x08)        # Baud Rate 0 (2 Mbps): not an AX's
    assert ph1.write2ByteTxRx(port, 1, PRESENT, 5) == (COMM_SUCCESS, 0x08)  # read-only
    assert ph1.write2ByteTxRx(port, 1, SPEED, 2048) == (COMM_SUCCESS, 0x08)    # Moving Speed 0..2047
    assert ph1.txRxPacket(port, list(build_instruction1(1, 0x08)))[2] == 0x40  # no reboot on an AX
    ax.shaft.supply_v = 15.0                                                    # above Max Voltage 14.0 V
    assert ph1.read1ByteTxRx(port, 1, 42)[1:] == (COMM_SUCCESS, 0x01)
    assert ph1.write1ByteTxRx(port, 1, 25, 1) == (COMM_SUCCESS, 0x01)       # every status carries it
    ax.shaft.supply_v = 12.0
    assert ph1.read1ByteTxRx(port, 1, 42) == (120, COMM_SUCCESS, 0)
    port.closePort()
    raw = make_raw(bus.path)
    bad = bytearray(build_instruction1(1, 0x02, bytes([43, 1])))
    bad[-1] ^= 0xFF
    assert raw.exchange(bytes(bad), 6) == build_status1(1, 0x10)             # checksum


def test_overheating_and_overload_shut_down_and_torque_limit_brings_it_back(make_bus, sdk1, manual_clock):
    bus = make_bus({1: AX12A}, clock=manual_clock)
    ax = bus.servos_at(1)[0]
    port, ph1 = sdk1(bus.path)
    assert ph1.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    ax.shaft.external_load = -0.8          # 80 % of the output pushing CW, Torque Limit 50 %
    assert ph1.write2ByteTxRx(port, 1, TORQUE_LIMIT, 512) == (COMM_SUCCESS, 0x20)
    assert ph1.read2ByteTxRx(port, 1, TORQUE_LIMIT) == (0, COMM_SUCCESS, 0x20)  # Shutdown (36) has overload
    assert ph1.read1ByteTxRx(port, 1, TORQUE)[0] == 1                           # torque stays "on", no output
    assert ph1.write2ByteTxRx(port, 1, TORQUE_LIMIT, 512) == (COMM_SUCCESS, 0x20)  # the load is still there
    assert ph1.read2ByteTxRx(port, 1, TORQUE_LIMIT)[0] == 0
    ax.shaft.external_load = 0.0
    assert ph1.write2ByteTxRx(port, 1, TORQUE_LIMIT, 1023) == (COMM_SUCCESS, 0)  # cleared, the Protocol 1.0 way
    assert ph1.read2ByteTxRx(port, 1, TORQUE_LIMIT) == (1023, COMM_SUCCESS, 0)
    ax.pin("present_temperature", 75)      # above its Temperature Limit 70
    assert ph1.read1ByteTxRx(port, 1, 43) == (75, COMM_SUCCESS, 0x04)
    assert ph1.read2ByteTxRx(port, 1, TORQUE_LIMIT)[0] == 0


def test_wheel_mode_turns_at_moving_speed_with_bit_10_the_direction(make_bus, sdk1, manual_clock):
    bus = make_bus({1: AX12A}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    assert ph1.write4ByteTxRx(port, 1, CW_LIMIT, 0) == (COMM_SUCCESS, 0)          # both Angle Limits 0
    assert bus.servos_at(1)[0].mode == "velocity"
    assert ph1.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, SPEED, 1024 + 300) == (COMM_SUCCESS, 0)     # 300 units CW
    manual_clock.advance(1.0)
    speed, result, _ = ph1.read2ByteTxRx(port, 1, PRESENT_SPEED)
    assert (speed, result) == (1024 + 300, COMM_SUCCESS)
    assert ph1.read2ByteTxRx(port, 1, LOAD)[0] >> 10 == 1                         # a CW load
    assert ph1.write2ByteTxRx(port, 1, SPEED, 1024) == (COMM_SUCCESS, 0)           # 1024 stops it, as 0
    manual_clock.advance(1.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT_SPEED)[0] in (0, 1024)
    assert ph1.write2ByteTxRx(port, 1, CCW_LIMIT, 1023) == (COMM_SUCCESS, 0)       # back to Joint Mode
    assert bus.servos_at(1)[0].mode == "position"


def test_joint_mode_moves_at_moving_speed_and_0_is_as_fast_as_it_goes(make_bus, sdk1, manual_clock):
    bus = make_bus({1: AX12A}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    assert ph1.write2ByteTxRx(port, 1, GOAL, 812) == (COMM_SUCCESS, 0)   # torque off: no move yet
    assert ph1.write2ByteTxRx(port, 1, SPEED, 100) == (COMM_SUCCESS, 0)  # 11.1 rpm = 66.6 deg/s
    manual_clock.advance(1.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT)[0] == 512
    assert ph1.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)   # the goal stays 812: it moves
    manual_clock.advance(0.5)
    position = ph1.read2ByteTxRx(port, 1, PRESENT)[0]
    assert position == pytest.approx(512 + 0.5 * 66.6 / (300 / 1023), abs=2)
    assert ph1.read2ByteTxRx(port, 1, PRESENT_SPEED)[0] == 100 and ph1.read1ByteTxRx(port, 1, 46)[0] == 1
    manual_clock.advance(5.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT)[0] == 812 and ph1.read1ByteTxRx(port, 1, 46)[0] == 0
    assert ph1.write2ByteTxRx(port, 1, SPEED, 0) == (COMM_SUCCESS, 0)    # 0: no speed control
    assert ph1.write2ByteTxRx(port, 1, GOAL, 112) == (COMM_SUCCESS, 0)
    manual_clock.advance(0.1)
    position = ph1.read2ByteTxRx(port, 1, PRESENT)[0]
    assert position == pytest.approx(812 - 0.1 * 1023 * 0.666 / (300 / 1023), abs=2)  # at 1023 units


def test_no_wheel_mode_on_dx_and_no_multi_turn_on_ex(make_bus, sdk1, manual_clock):
    bus = make_bus({1: 117, 2: EX106}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    assert ph1.write4ByteTxRx(port, 1, CW_LIMIT, 0) == (COMM_SUCCESS, 0)       # DX-117: both limits 0
    assert ph1.write2ByteTxRx(port, 2, CW_LIMIT, 4095) == (COMM_SUCCESS, 0)    # EX-106+: both 4095
    assert [bus.servos_at(sid)[0].mode for sid in (1, 2)] == ["position", "position"]
    for sid in (1, 2):
        assert ph1.write1ByteTxRx(port, sid, TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, SPEED, 300) == (COMM_SUCCESS, 0)
    manual_clock.advance(1.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT_SPEED)[0] == 0  # it does not turn endlessly


def test_multi_turn_on_mx_with_its_offset(make_bus, sdk1, manual_clock):
    bus = make_bus({1: MX28}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    assert ph1.write2ByteTxRx(port, 1, CW_LIMIT, 4095) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, CCW_LIMIT, 4095) == (COMM_SUCCESS, 0)
    assert bus.servos_at(1)[0].mode == "ex_position"
    assert ph1.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, GOAL, 2048 + 3 * 4096) == (COMM_SUCCESS, 0)  # three turns on
    manual_clock.advance(10.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT)[0] == 2048 + 3 * 4096
    goal = (-2000) & 0xFFFF                                                    # two's complement
    assert ph1.write2ByteTxRx(port, 1, GOAL, goal) == (COMM_SUCCESS, 0)
    manual_clock.advance(15.0)
    assert ph1.read2ByteTxRx(port, 1, PRESENT)[0] == goal
    assert ph1.write2ByteTxRx(port, 1, 20, 1024) == (COMM_SUCCESS, 0)         # Multi Turn Offset
    assert ph1.read2ByteTxRx(port, 1, PRESENT)[0] == (-2000 + 1024) & 0xFFFF
    assert ph1.write2ByteTxRx(port, 1, 20, 30000) == (COMM_SUCCESS, 0x08)      # beyond 24,576


def test_torque_control_on_mx64_and_its_current(make_bus, sdk1, manual_clock):
    bus = make_bus({1: MX64, 2: AX12A}, clock=manual_clock)
    port, ph1 = sdk1(bus.path)
    assert ph1.read2ByteTxRx(port, 1, 68)[:2] == (2048, COMM_SUCCESS)       # Current: 2048 is 0 mA
    assert ph1.write1ByteTxRx(port, 1, TORQUE, 1) == (COMM_SUCCESS, 0)
    assert ph1.write2ByteTxRx(port, 1, 71, 100) == (COMM_SUCCESS, 0)        # Goal Torque 450 mA CCW
    assert ph1.write1ByteTxRx(port, 1, 70, 1) == (COMM_SUCCESS, 0)          # Torque Control Mode Enable
    assert bus.servos_at(1)[0].mode == "current"
    manual_clock.advance(1.0)
    assert ph1.read2ByteTxRx(port, 1, 68)[0] == 2048 + 100
    assert ph1.read2ByteTxRx(port, 1, PRESENT_SPEED)[0] > 0
    assert ph1.write2ByteTxRx(port, 1, 71, 1024 + 50) == (COMM_SUCCESS, 0)  # 225 mA CW
    assert ph1.read2ByteTxRx(port, 1, 68)[0] == 2048 - 50
    assert ph1.write1ByteTxRx(port, 2, 70, 1) == (COMM_SUCCESS, 0x08)       # an AX has no such item
    assert ph1.read1ByteTxRx(port, 2, 70)[2] == 0x08


def test_a_protocol_2_servo_on_the_same_id_does_not_collide(make_bus, make_sdk):
    bus = make_bus([(1, AX12A), (1, XM430)])
    port, ph2 = make_sdk(bus.path)
    ph1 = PacketHandler(1.0)
    for _ in range(3):
        assert ph1.ping(port, 1) == (AX12A, COMM_SUCCESS, 0)
        assert ph2.ping(port, 1) == (XM430, COMM_SUCCESS, 0)
    assert ph1.write1ByteTxRx(port, 1, 25, 1) == (COMM_SUCCESS, 0)          # the AX's LED (25)
    assert ph2.read1ByteTxRx(port, 1, 65) == (0, COMM_SUCCESS, 0)           # the XM's LED (65) untouched
    assert bus.servos_at(1)[0].read("led") == 1


def test_the_sdk_reads_a_bare_error_status_as_the_checksum_byte(make_bus, sdk1):
    bus = make_bus({1: AX12A})
    port, ph1 = sdk1(bus.path)
    value, result, error = ph1.read1ByteTxRx(port, 1, 60)   # beyond the AX's table: Range Error, no data
    assert (result, error) == (COMM_SUCCESS, 0x08)
    assert value == checksum(bytes([1, 2, 0x08]))           # dynamixel_sdk 4.1.0: the checksum as the value
    with pytest.raises(IndexError):                          # ... and the 2-byte read fails outright
        ph1.read2ByteTxRx(port, 1, 60)
    assert ph1.read1ByteTxRx(port, 1, 3) == (1, COMM_SUCCESS, 0)  # the next transaction is clean


def test_the_command_line_takes_every_protocol1_name():
    from dynamixel_handler.sim.cli import parse_model
    names = {"AX-12A": 12, "AX-12": 12, "AX-12W": 300, "AX-18A": 18, "RX-10": 10, "RX-24F": 24, "RX-28": 28,
             "RX-64": 64, "DX-113": 113, "DX-116": 116, "DX-117": 117, "EX-106+": 107, "MX-12W": 360,
             "MX-28(1.0)": 29, "MX-64(1.0)": 310, "MX-106(1.0)": 320, "310": 310, "107": 107}
    assert {name: parse_model(name) for name in names} == names
    assert parse_model("MX-64") == 311  # the 2.0 firmware wins a name both have


def test_the_state_file_keeps_a_wheel_mode_and_a_baud_rate(tmp_path, make_bus, sdk1):
    from dynamixel_handler.sim import VirtualBus
    state = str(tmp_path / "bus.json")
    bus = make_bus({3: EX106, 4: MX64}, state_file=state)
    port, ph1 = sdk1(bus.path)
    assert ph1.write4ByteTxRx(port, 3, CW_LIMIT, 0) == (COMM_SUCCESS, 0)      # EX-106+ to Wheel Mode
    assert ph1.write1ByteTxRx(port, 4, 4, 250) == (COMM_SUCCESS, 0)           # MX-64 to 2.25 Mbps
    bus.save_state()
    again = VirtualBus(state_file=state, wire_timing=False)
    ex, mx = again.servos_at(3)[0], again.servos_at(4)[0]
    assert (ex.model.name, ex.mode, ex.read("torque_limit")) == ("EX-106+", "velocity", 1023)
    assert (mx.model.name, mx.baudrate) == ("MX-64", 2_250_000)
