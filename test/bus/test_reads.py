"""Reads: pings, the sync read packet and what it gathers, the scan."""
from __future__ import annotations

from conftest import instruction, status

from dynamixel_handler.bus.reads import Reads
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.protocol.framers import PROTOCOL2


def _answering(present: dict[int, bytes]):
    def answer(packet: bytes) -> list[bytes]:
        if packet[7] == 0x82:  # sync read: the IDs after address and length
            return [status(i, present[i]) for i in packet[12:-2] if i in present]
        return []
    return answer


def test_a_ping_gives_the_model_and_notes_the_firmware(line):
    peer, transport = line(lambda packet: [status(1, b"\x14\x04\x2d")])
    reads = Reads(transport)
    result = reads.ping(1, framer=PROTOCOL2)
    assert result.value == 1044 and result.failure is None and result.why == ""
    assert reads.firmware_versions == {1: 0x2D}
    assert peer.received == [instruction(1, 0x01)]


def test_a_silent_ping_is_none_and_says_why(line):
    _, transport = line()
    result = Reads(transport).ping(4, retries=0, framer=PROTOCOL2)
    assert result.value is None and result.failure is Failure.NO_REPLY and result.why.startswith("ping ID 4: no reply within")


def test_a_sync_read_keeps_the_servos_that_answered(line):
    peer, transport = line(_answering({1: b"\x10\x00", 3: b"\x30\x00"}))
    read = Reads(transport).start_sync_read(132, 2, (1, 2, 3), protocol=2)
    assert read.result() == {1: b"\x10\x00", 3: b"\x30\x00"} and read.failure is None
    assert peer.received == [instruction(0xFE, 0x82, bytes([0x84, 0x00, 0x02, 0x00, 1, 2, 3]))]


def test_the_same_sync_read_reuses_its_packet_and_ids_are_checked_once(line):
    _, transport = line(_answering({1: b"\x01"}))
    reads = Reads(transport)
    first = reads.start_sync_read(146, 1, (1, 1), protocol=2)
    assert first.result() == {1: b"\x01"}
    second = reads.start_sync_read(146, 1, (1, 1), protocol=2)
    assert second.packet is first.packet and second.expected == [(1, 1)]


def test_a_read_of_no_servo_sends_nothing(line):
    peer, transport = line()
    read = Reads(transport).start_sync_read(132, 4, (), protocol=2)
    assert read.done and read.result() == {} and peer.received == []


def test_a_wide_scan_is_one_broadcast_ping(line):
    def answer(packet: bytes) -> list[bytes]:
        return [status(2, b"\x26\x04\x30"), status(5, b"\xe4\x07\x0c")] if packet[4] == 0xFE else []

    peer, transport = line(answer)
    assert Reads(transport).scan(range(1, 8)) == {2: 1062, 5: 2020}
    assert peer.received == [instruction(0xFE, 0x01)]


def test_a_narrow_scan_pings_each_id_once(line):
    peer, transport = line(lambda packet: [status(3, b"\x14\x04\x2d")] if packet[4] == 3 else [])
    assert Reads(transport).scan([4, 3]) == {3: 1044}
    assert peer.received == [instruction(3, 0x01), instruction(4, 0x01)]  # not retried
