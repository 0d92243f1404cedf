"""Receiver: how long a reply is waited for, and which bytes are taken as the answer."""
from __future__ import annotations

import pytest
from conftest import Peer, status

from dynamixel_handler.bus.transport import Transport
from dynamixel_handler.protocol.framers import PROTOCOL2


def test_the_reply_wait_is_two_latencies_the_wire_time_and_the_margin(line):
    _, transport = line(latency_timer_ms=4.0, baudrate=1_000_000, timeout_margin_ms=2.0)
    # 10 bits a byte at 1 Mbps: 0.01 ms a byte
    assert transport.rx.reply_timeout_ms(14, 15) == pytest.approx(2 * 4.0 + 29 * 0.01 + 2.0)


def test_a_late_reply_of_another_servo_is_not_taken_as_the_answer(line):
    peer, transport = line(lambda packet: [status(2, b"\x01\x00"), status(1, b"\x05\x00")])
    transport.send(b"\xff\xff\xfd\x00\x01\x07\x00\x02\x84\x00\x02\x00\x00\x00")  # any packet
    got = transport.rx.gather([(1, 2)], 14, False, framer=PROTOCOL2)
    assert got is not None and list(got) == [1] and got[1].params == b"\x05\x00"
    assert transport.stats.discarded_bytes >= 13


def test_a_reply_of_the_wrong_length_is_not_taken_either(line):
    _, transport = line(lambda packet: [status(1, b"\x05")], retry_num=0)
    transport.send(b"\xff\xff\xfd\x00\x01\x03\x00\x01\x00\x00")
    assert transport.rx.gather([(1, 2)], 10, False, framer=PROTOCOL2) == {}
    assert transport.stats.timeouts == 1


def test_the_error_byte_of_every_status_is_kept_with_it(line):
    _, transport = line(lambda packet: [status(1, b"\x00", error=0x80)])
    transport.send(b"\xff\xff\xfd\x00\x01\x03\x00\x01\x00\x00")
    got = transport.rx.gather([(1, 1)], 10, False, framer=PROTOCOL2)
    assert got is not None and 1 in got  # the alert bit alone: the data is good
    assert got[1].error == 0x80


def test_a_device_lost_mid_run_is_counted_once_and_fails_fast():
    peer = Peer(lambda packet: [])
    lines: list[str] = []
    transport = Transport(peer.path, latency_timer_ms=1.0, logger=type("L", (), {"error": lines.append})())
    try:
        transport.open()
        transport.rx.lose(OSError("gone"))
        transport.rx.lose(OSError("gone again"))
        assert transport.stats.disconnects == 1 and len(lines) == 1 and "stopped working" in lines[0]
        assert transport.why(None)[1] == "device lost" and transport.send(b"\x00") is False
    finally:
        transport.close()
        peer.close()
