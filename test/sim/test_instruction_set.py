"""InstructionSet: which servos hear a packet, the replies they give, what is logged and refused."""
from __future__ import annotations

import collections

from dynamixel_handler.protocol import host
from dynamixel_handler.protocol import servo as p
from dynamixel_handler.sim.instructions import InstructionSet
from dynamixel_handler.sim.servo import VirtualServo

XM430 = 1020


def packet(dxl_id: int, inst: int, params: bytes = b"") -> p.Packet:
    return p.PacketParser().feed(host.build_instruction(dxl_id, inst, params))[0]


def instruction_set(*ids: int) -> tuple[InstructionSet, list[VirtualServo]]:
    def clock() -> float:
        return 100.0
    servos = [VirtualServo(XM430, i, clock) for i in ids]
    return InstructionSet(servos, clock, collections.deque(), collections.Counter(), collections.deque()), servos


def test_a_broadcast_ping_is_answered_by_every_servo_in_id_order():
    ins, servos = instruction_set(3, 1, 2)
    replies = ins.execute(packet(p.BROADCAST_ID, p.PING))
    assert [reply[4] for _, reply in replies] == [1, 2, 3]
    firmware = servos[0].read("firmware_version")
    assert all(reply[9:12] == bytes([0xFC, 0x03, firmware]) for _, reply in replies)  # model 1020


def test_a_silent_servo_hears_nothing():
    ins, servos = instruction_set(1, 2)
    servos[0].silent = True
    assert [reply[4] for _, reply in ins.execute(packet(p.BROADCAST_ID, p.PING))] == [2]
    assert ins.execute(packet(1, p.PING)) == []


def test_a_servo_at_another_baud_rate_hears_nothing_while_the_line_is_checked():
    ins, _ = instruction_set(1)  # factory: 57600 bps
    ins.line_bps = 1_000_000
    assert ins.execute(packet(1, p.PING)) == []
    ins.line_bps = 57600
    assert len(ins.execute(packet(1, p.PING))) == 1


def test_a_refused_write_is_answered_with_its_error_and_kept():
    ins, servos = instruction_set(1)
    servos[0].write("torque_enable", 1)
    replies = ins.execute(packet(1, p.WRITE, bytes([11, 0, 1])))  # operating mode: EEPROM, torque on
    assert len(replies) == 1 and replies[0][1][8] == p.ERR_ACCESS
    assert [(dxl_id, address, error) for _, dxl_id, address, _, error in ins.refused] == [(1, 11, p.ERR_ACCESS)]


def test_a_sync_write_writes_each_listed_servo_and_gets_no_reply():
    ins, servos = instruction_set(1, 2)
    params = bytes([65, 0, 1, 0, 1, 1, 2, 0])  # LED: ID 1 on, ID 2 off
    assert ins.execute(packet(p.BROADCAST_ID, p.SYNC_WRITE, params)) == []
    assert servos[0].read("led") == 1 and servos[1].read("led") == 0


def test_every_packet_is_logged_and_counted():
    log: collections.deque = collections.deque()
    servos = [VirtualServo(XM430, 1, lambda: 100.0)]
    ins = InstructionSet(servos, lambda: 100.0, log, collections.Counter(), collections.deque())
    ins.execute(packet(1, p.PING))
    unknown = ins.execute(packet(1, 0x7F))  # an unknown instruction: the servo says so
    assert unknown[0][1][8] == p.ERR_INSTRUCTION
    assert ins.stats["instructions"] == 2
    assert [entry.instruction for entry in log] == [p.PING, 0x7F]
