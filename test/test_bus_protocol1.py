"""Protocol 1.0 servos through the bus layer, beside Protocol 2.0 ones on one line: each
instruction value says the protocol its servo speaks, and the bus frames it with that protocol's
framer. The packets are checked byte for byte against the e-Manual's Protocol 1.0 examples, and
end to end against the virtual bus's Protocol 1.0 servos (a real peer on a pty)."""
from __future__ import annotations

import pytest

from dynamixel_handler.bus import DynamixelBus, Failure
from dynamixel_handler.bus.ops import ClearError, ClearMultiTurn, Ping, Read, SyncRead, Write
from dynamixel_handler.bus.writes import Writes
from dynamixel_handler.protocol import protocol1 as p1
from dynamixel_handler.protocol.framers import FRAMERS, PROTOCOL1
from dynamixel_handler.sim import VirtualBus

AX12A, XM430 = 12, 1020
LED1, GOAL_POSITION1, MODEL_NUMBER1 = 25, 30, 0


# ------------------------------------------------------------------ the wire format
def test_instruction_packets_are_those_of_the_emanual_examples():
    # e-Manual, Protocol 1.0: ping ID 1; read ID 1's present temperature (address 43, 1 byte)
    assert p1.build_instruction(1, p1.PING) == bytes.fromhex("FF FF 01 02 01 FB")
    assert p1.build_instruction(1, p1.READ, p1.read_params(0x2B, 1)) == bytes.fromhex("FF FF 01 04 02 2B 01 CC")
    # its status: 32 degC, no error
    assert p1.statuses(bytes.fromhex("FF FF 01 03 00 20 DB")) == [p1.Status1(1, 0, b"\x20")]


def test_a_status_is_found_behind_noise_a_protocol2_packet_and_a_bad_checksum():
    good = p1.build_packet(3, 0, b"\x00\x02")
    bad = bytearray(p1.build_packet(4, 0, b"\x01"))
    bad[-1] ^= 0xFF
    protocol2 = FRAMERS[2].instruction(1, 0x01)
    stream = p1.StatusStream1()
    found = stream.feed(b"\x00\xff\x12" + protocol2 + bytes(bad) + good[:4])
    assert found == [] and stream.crc_errors == 1
    assert stream.feed(good[4:]) == [p1.Status1(3, 0, b"\x00\x02")]


def test_which_error_bits_say_the_instruction_was_not_carried_out():
    assert p1.Status1(1, p1.ERR_RANGE, b"").refused and p1.Status1(1, p1.ERR_INSTRUCTION, b"").refused
    assert p1.Status1(1, p1.ERR_ANGLE_LIMIT, b"").refused and p1.Status1(1, p1.ERR_CHECKSUM, b"").refused
    for state in (p1.ERR_OVERLOAD, p1.ERR_OVERHEATING, p1.ERR_VOLTAGE):  # the servo's state, the write done
        assert not p1.Status1(1, state, b"").refused
    assert p1.error_text(p1.ERR_OVERLOAD | p1.ERR_VOLTAGE) == "input voltage, overload error (0x21)"
    assert PROTOCOL1.corrupted(p1.ERR_CHECKSUM) and not PROTOCOL1.corrupted(p1.ERR_RANGE)


def test_a_sync_write_in_protocol1_has_one_byte_addresses_and_a_checksum():
    prepared = Writes.prepare_sync_write(GOAL_POSITION1, 2, {1: b"\x00\x02", 2: b"\xff\x03"}, protocol=1)
    body = bytes([0xFE, 10, 0x83, GOAL_POSITION1, 2, 1, 0x00, 0x02, 2, 0xFF, 0x03])
    assert prepared.packet == b"\xff\xff" + body + bytes([~sum(body) & 0xFF])
    with pytest.raises(ValueError, match="at most 141 bytes"):
        p1.build_instruction(0xFE, p1.SYNC_WRITE, bytes(142))


# ------------------------------------------------------------------ on a mixed line
@pytest.fixture
def mixed():
    """An AX-12A (Protocol 1.0) at ID 7 and an XM430 (2.0) at ID 1, both at 1 Mbps, and the bus."""
    with VirtualBus({7: AX12A, 1: XM430}, baudrate=1_000_000, wire_timing=False) as sim:
        bus = DynamixelBus(sim.path, baudrate=1_000_000, retry_num=2, retry_interval_ms=1.0)
        bus.open()
        yield sim, bus
        bus.close()


def test_each_servo_answers_in_its_own_protocol_on_one_line(mixed):
    sim, bus = mixed
    assert bus.execute(Ping(7, protocol=1)).value == AX12A
    assert bus.execute(Ping(1, protocol=2)).value == XM430
    # the firmware comes with a 2.0 status; a 1.0 servo's is an item of its model, not guessed
    assert bus.firmware_versions == {1: sim.servos_at(1)[0].read("firmware_version")}
    silent = bus.execute(Ping(7, retries=0, protocol=2))           # the AX ignores Protocol 2.0
    assert silent.value is None and silent.failure is Failure.NO_REPLY
    assert bus.execute(Ping(1, retries=0, protocol=1)).failure is Failure.NO_REPLY  # and the XM 1.0
    assert bus.execute(Read(7, MODEL_NUMBER1, 2, protocol=1)).value == AX12A.to_bytes(2, "little")


def test_a_protocol1_write_lands_and_reads_back(mixed):
    sim, bus = mixed
    ax = sim.servos_at(7)[0]
    assert bus.execute(Write(7, LED1, b"\x01", protocol=1))
    assert ax.read("led") == 1
    assert bus.execute(Read(7, LED1, 1, protocol=1)).value == b"\x01"
    goal = bus.prepare_sync_write(GOAL_POSITION1, 2, {7: (300).to_bytes(2, "little")}, protocol=1)
    assert bus.execute(goal) and bus.execute(Read(7, GOAL_POSITION1, 2, protocol=1)).value == (300).to_bytes(2, "little")
    assert ax.read("goal_position") == 300


def test_a_protocol1_refusal_is_a_refused_result_with_the_error_bits_in_words(mixed):
    sim, bus = mixed
    refused = bus.execute(Write(7, MODEL_NUMBER1, b"\x00\x00", protocol=1))   # read-only
    assert refused.value is False and refused.failure is Failure.REFUSED
    assert refused.why.startswith("write ID 7: ") and "error (0x" in refused.why
    assert sim.servos_at(7)[0].read("model_number") == AX12A


def test_instructions_protocol1_lacks_are_refused_without_sending(mixed):
    _, bus = mixed
    sent = bus.stats.packets_sent
    for op in (ClearMultiTurn(7, protocol=1), ClearError(7, b"\x02", protocol=1)):
        got = bus.execute(op)
        assert got.value is False and got.failure is Failure.NOT_IN_PROTOCOL and "Protocol 1.0" in got.why
    assert bus.stats.packets_sent == sent


def test_mx_servos_are_read_in_one_bulk_read_and_the_ax_one_by_one():
    MX28 = 29
    with VirtualBus({7: AX12A, 8: AX12A, 2: MX28, 3: MX28}, baudrate=1_000_000, wire_timing=False) as sim:
        bus = DynamixelBus(sim.path, baudrate=1_000_000, retry_num=2, retry_interval_ms=1.0)
        bus.open()
        try:
            sent = bus.stats.packets_sent
            mx = bus.execute(SyncRead(36, 2, (2, 3), fast=True, protocol=1))   # Present Position
            assert bus.stats.packets_sent == sent + 1                              # one Bulk Read
            assert set(mx.value) == {2, 3} and all(len(d) == 2 for d in mx.value.values())
            sent = bus.stats.packets_sent
            ax = bus.execute(SyncRead(36, 2, (7, 8), protocol=1))
            assert bus.stats.packets_sent == sent + 2 and set(ax.value) == {7, 8}  # a read each
            assert int.from_bytes(ax.value[7], "little") == sim.servos_at(7)[0].read("present_position")
        finally:
            bus.close()
