"""Writes: the bytes of a sync write (built ahead, sent later) and a bulk write, and the Result."""
from __future__ import annotations

from conftest import instruction

from dynamixel_handler.bus.result import Failure
from dynamixel_handler.bus.writes import Writes


def test_a_prepared_sync_write_encodes_each_servo_s_data_in_order():
    prepared = Writes.prepare_sync_write(116, 4, {3: b"\x00\x08\x00\x00", 1: b"\xff\x07\x00\x00"}, protocol=2)
    assert prepared.ids == (3, 1)
    assert prepared.packet == instruction(0xFE, 0x83, bytes([0x74, 0x00, 0x04, 0x00,
                                                              3, 0x00, 0x08, 0x00, 0x00,
                                                              1, 0xFF, 0x07, 0x00, 0x00]))


def test_a_prepared_write_goes_out_as_built_and_is_true_when_sent(line):
    peer, transport = line()
    prepared = Writes.prepare_sync_write(64, 1, {1: b"\x01", 2: b"\x01"}, protocol=2)
    result = Writes(transport).send_prepared(prepared)
    assert result.value is True and result.failure is None
    assert peer.wait_for(1) == [prepared.packet]


def test_nothing_to_write_sends_nothing(line):
    peer, transport = line()
    writes = Writes(transport)
    assert writes.send_prepared(Writes.prepare_sync_write(64, 1, {}, protocol=2)).value is True
    assert writes.bulk_write({}).value is True
    assert peer.received == [] and transport.stats.packets_sent == 0


def test_a_bulk_write_carries_each_servo_s_own_address(line):
    peer, transport = line()
    assert Writes(transport).bulk_write({1: (64, b"\x01"), 2: (116, b"\x10\x00\x00\x00")}).value is True
    assert peer.wait_for(1) == [instruction(0xFE, 0x93, bytes([1, 0x40, 0x00, 0x01, 0x00, 0x01,
                                                               2, 0x74, 0x00, 0x04, 0x00, 0x10, 0, 0, 0]))]


def test_a_write_on_a_closed_port_is_false_and_says_why(line):
    _, transport = line()
    transport.close()
    result = Writes(transport).send_prepared(Writes.prepare_sync_write(64, 1, {1: b"\x01"}, protocol=2))
    assert result.value is False and result.failure is Failure.PORT_CLOSED and result.why == "sync write @64x1: port closed"
