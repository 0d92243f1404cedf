"""Instructions: what a single-servo call sends and the Result it returns (value and why not)."""
from __future__ import annotations

import pytest
from conftest import instruction, status

from dynamixel_handler.bus.instructions import Instructions
from dynamixel_handler.bus.ops import Action, ClearMultiTurn, FactoryReset, Read, Reboot, Write
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.protocol.framers import PROTOCOL2


def test_a_read_returns_the_data_and_no_failure(line):
    peer, transport = line(lambda packet: [status(1, b"\x00\x08\x00\x00")])
    result = Instructions(transport).execute(Read(1, 132, 4, protocol=2), PROTOCOL2)
    assert result.value == b"\x00\x08\x00\x00" and result.failure is None and result
    # the read instruction, sent again only if the peer's reply came late on a loaded machine
    assert set(peer.received) == {instruction(1, 0x02, bytes([0x84, 0x00, 0x04, 0x00]))}


def test_a_failed_read_returns_none_and_why(line):
    _, transport = line(retry_num=1)
    result = Instructions(transport).execute(Read(3, 132, 4, protocol=2), PROTOCOL2)
    assert result.value is None and not result
    assert result.why.startswith("read ID 3 @132x4: no reply within")


def test_a_refused_write_returns_false_and_the_servo_s_error(line):
    _, transport = line(lambda packet: [status(1, error=0x07)])
    result = Instructions(transport).execute(Write(1, 116, b"\x00\x00\x00\x00", protocol=2), PROTOCOL2)
    assert result.value is False and result.why.startswith("write ID 1: ")
    assert result.failure is Failure.REFUSED and "access" in result.why.lower()
    assert result.error == 0x07  # the status error byte travels with the result


def test_an_answered_read_carries_the_status_error_byte(line):
    _, transport = line(lambda packet: [status(1, b"\x2a", error=0x80)])  # hardware error flag
    result = Instructions(transport).execute(Read(1, 65, 1, protocol=2), PROTOCOL2)
    assert result.value == b"\x2a" and result.ok and result.error == 0x80


def test_an_acknowledged_reboot_is_true(line):
    peer, transport = line(lambda packet: [status(7)])
    result = Instructions(transport).execute(Reboot(7, protocol=2), PROTOCOL2)
    assert result.value is True and result.ok
    assert peer.received == [instruction(7, 0x08)]


def test_an_unanswered_reboot_is_sent_once_whatever_the_retry_count(line):
    """A reboot whose acknowledgement was lost may have happened: sent again, it would reboot the
    servo a second time."""
    peer, transport = line(retry_num=3)
    result = Instructions(transport).execute(Reboot(7, protocol=2), PROTOCOL2)
    assert result.value is False and result.why.startswith("reboot ID 7: no reply within")
    assert peer.received == [instruction(7, 0x08)]
    peer2, transport2 = line(retry_num=3)
    Instructions(transport2).execute(Write(7, 116, b"\x00\x00\x00\x00", protocol=2), PROTOCOL2)  # a write is retried as asked
    assert len(peer2.received) == 4


def test_a_broadcast_action_waits_for_no_reply(line):
    peer, transport = line(lambda packet: [])
    result = Instructions(transport).execute(Action(protocol=2), PROTOCOL2)
    assert result.value is True
    assert peer.wait_for(1) == [instruction(0xFE, 0x05)]
    assert transport.stats.timeouts == 0


def test_clear_multi_turn_sends_the_clear_key(line):
    peer, transport = line(lambda packet: [status(2)])
    assert Instructions(transport).execute(ClearMultiTurn(2, protocol=2), PROTOCOL2).value is True
    assert peer.received == [instruction(2, 0x10, b"\x01\x44\x58\x4c\x22")]


def test_a_bad_factory_reset_option_sends_nothing(line):
    peer, transport = line()
    with pytest.raises(ValueError, match="0x01, 0x02 or 0xFF"):
        FactoryReset(1, 0x03, protocol=2)
    with pytest.raises(ValueError, match="invalid Dynamixel ID"):
        Write(300, 64, b"\x01", protocol=2)
    assert peer.received == []


def test_a_failure_kind_reads_as_words_in_a_log_line(line):
    _, transport = line(retry_num=0)
    result = Instructions(transport).execute(Write(4, 64, b"\x01", protocol=2), PROTOCOL2)
    assert f"torque on failed: {result.failure}" == "torque on failed: no reply"
