"""Transport: one transaction at a time on the line, retries, the read left in flight, and what a
failed transaction reports."""
from __future__ import annotations

import time

import pytest
from conftest import instruction, status

from dynamixel_handler.bus.errors import BusError
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.bus.transport import Transport
from dynamixel_handler.protocol.framers import PROTOCOL2

PING = instruction(1, 0x01)


def received(peer, n: int) -> list[bytes]:
    """What the peer has read, once it has read ``n`` packets (its thread may lag on a loaded host)."""
    deadline = time.monotonic() + 5.0
    while len(peer.received) < n and time.monotonic() < deadline:
        time.sleep(0.01)
    return list(peer.received)


def test_a_silent_servo_gets_the_same_packet_again_until_retries_run_out(line):
    peer, transport = line(retry_num=2)
    assert transport.unicast(1, 0x01, b"", 3, framer=PROTOCOL2) is None
    assert received(peer, 3) == [PING, PING, PING]
    assert transport.stats.retries == 2 and transport.stats.packets_sent == 3
    assert transport.why(None) == (Failure.NO_REPLY, transport.why(None)[1]) and transport.why(None)[1].startswith("no reply within")


def test_a_retry_that_is_answered_ends_the_retries(line):
    answers = iter([[], [status(1, b"\x14\x04\x2d")]])
    peer, transport = line(lambda packet: next(answers, []), retry_num=5)
    reply = transport.unicast(1, 0x01, b"", 3, framer=PROTOCOL2)
    assert reply is not None and reply.params == b"\x14\x04\x2d"
    assert received(peer, 2) == [PING, PING] and transport.stats.retries == 1


def test_a_servo_crc_error_is_retried_but_a_refusal_is_an_answer(line):
    answers = iter([[status(1, error=0x03)], [status(1, error=0x07)]])
    peer, transport = line(lambda packet: next(answers, []))
    reply = transport.unicast(1, 0x03, b"\x40\x00\x01", 0, framer=PROTOCOL2)
    assert reply is not None and reply.error == 0x07  # access error: the servo's answer, not retried
    assert len(peer.received) == 2
    assert transport.why(reply, framer=PROTOCOL2)[0] is Failure.REFUSED and "access" in transport.why(reply, framer=PROTOCOL2)[1].lower()


def test_a_failed_transaction_counts_and_says_why(line):
    _, transport = line(retry_num=0)
    with transport.transaction() as tx:
        reason = tx.fail("read ID 1 @132x4: no reply")
    assert reason == "read ID 1 @132x4: no reply"
    assert transport.stats.transactions == 1 and transport.stats.successes == 0
    with transport.transaction() as tx:
        tx.ok(1, 2)
    assert transport.stats.successes == 1 and transport.stats.full_successes == 0


def test_a_read_in_flight_is_gathered_before_the_next_packet_goes_out(line):
    def answer(packet: bytes) -> list[bytes]:
        return [status(1, b"\x2a\x00"), status(2, b"\x2b\x00")] if packet[7] == 0x82 else [status(1)]

    peer, transport = line(answer)
    read_packet = instruction(0xFE, 0x82, bytes([0x84, 0x00, 0x02, 0x00, 1, 2]))
    read = transport.start_group_read(read_packet, [(1, 2), (2, 2)], False, "sync read @132x2", framer=PROTOCOL2)
    assert transport.inflight_eta is not None and not read.done
    with transport.transaction():
        transport.unicast(1, 0x03, b"\x41\x00\x01", 0, framer=PROTOCOL2)  # an LED write while the read is on the wire
    assert read.done and read.result() == {1: b"\x2a\x00", 2: b"\x2b\x00"} and read.failure is None
    assert [p[7] for p in peer.received] == [0x82, 0x03]
    assert transport.inflight_eta is None


def test_a_group_read_nobody_answers_is_sent_again_and_says_so(line):
    peer, transport = line(retry_num=1)
    packet = instruction(0xFE, 0x82, bytes([0x84, 0x00, 0x02, 0x00, 1]))
    read = transport.start_group_read(packet, [(1, 2)], False, "sync read @132x2", framer=PROTOCOL2)
    assert read.result() == {}
    assert read.failure is Failure.NOBODY_ANSWERED and read.why == "sync read @132x2: no servo answered"
    deadline = time.monotonic() + 5.0  # the peer's thread may not have taken the second one in yet
    while len(peer.received) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert received(peer, 2) == [packet, packet]


def test_sending_on_a_port_never_opened_is_an_error_not_a_silent_failure(line):
    peer, _ = line()
    closed = Transport(peer.path, latency_timer_ms=1.0)
    with pytest.raises(BusError, match="not open"):
        closed.send(PING)


def test_a_closed_port_fails_at_once_without_sending(line):
    peer, transport = line()
    transport.close()
    assert transport.send(PING) is False
    assert transport.why(None)[1] == "port closed" and peer.received == []
