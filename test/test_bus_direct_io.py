"""The port's bytes through ``os.read``/``os.write`` (``direct_io``, the default) and through
pyserial's ``read``/``write`` give the same replies from the same wire bytes.

A scripted peer on a real pty answers each instruction with the same bytes, in the same pieces,
to a bus of each kind: clean replies, noise before and between them, a corrupted packet, a silent
servo, a truncated fast-read reply, bytes left over from before, and the device vanishing. Both
buses must decode the same data, count the same CRC errors, discarded bytes and timeouts, and
log the same line when the device goes away.
"""
from __future__ import annotations

import time

import pytest
from test_bus_wire import WirePeer, fast_reply, status

from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.bus.ops import SyncRead
from dynamixel_handler.protocol.host import build_instruction

DATA = {1: bytes(range(10, 20)), 2: bytes([0xFF, 0xFF, 0xFD, 0x00, 2, 2, 2, 0xFD, 0xFD, 0x55]),
        3: bytes(range(30, 40))}
#: the bus of every run: 1 Mbps, 1 ms latency, no retries; a reply timeout with room for a busy
#: host (the peer is a thread of this process), which changes no count below
BUS = {"latency_timer_ms": 1, "retry_num": 0, "timeout_margin_ms": 50.0}
NOISE = bytes([0x00, 0xFF, 0x13, 0xFF, 0xFF, 0xFD, 0x55, 0xFF])


def _corrupt(packet: bytes) -> bytes:
    return packet[:-1] + bytes([packet[-1] ^ 0x5A])


def _replies(*ids: int) -> list[bytes]:
    return [status(i, DATA[i]) for i in ids]


ECHO = build_instruction(0xFE, 0x82, bytes([126, 0, 10, 0, 1, 2, 3]))  # our own sync read, echoed back
ALL = (1, 2, 3)

#: name -> (fast read?, what the peer writes after each instruction: bytes, or seconds to wait,
#:          IDs decoded, CRC errors and timeouts counted over the two reads)
SCRIPTS = {
    "clean, one piece": (False, [b"".join(_replies(1, 2, 3))], ALL, 0, 0),
    "one packet at a time": (False, [*_replies(1), 0.0005, *_replies(2), 0.0005, *_replies(3)], ALL, 0, 0),
    "noise before and between": (False, [NOISE, _replies(1)[0][:5], 0.0005, _replies(1)[0][5:] + NOISE,
                                         0.0005, b"".join(_replies(2, 3))], ALL, 0, 0),
    "a corrupted packet": (False, [_replies(1)[0] + _corrupt(_replies(3)[0]) + _replies(2)[0]], (1, 2), 2, 2),
    # after the bad CRC the search finds the header inside servo 2's data, whose length swallows servo 3
    "a corrupted packet before a header in the data": (False, [_replies(1)[0] + _corrupt(_replies(2)[0])
                                                               + _replies(3)[0]], (1,), 2, 2),
    "a silent servo": (False, [b"".join(_replies(1, 3))], (1, 3), 0, 2),
    "an echoed instruction and a wrong ID": (False, [ECHO, status(7, DATA[1]), b"".join(_replies(1, 2, 3))],
                                             ALL, 0, 0),
    "fast, clean": (True, [fast_reply([(i, DATA[i]) for i in ALL])], ALL, 0, 0),
    "fast, noise first and in pieces": (True, [NOISE, fast_reply([(i, DATA[i]) for i in ALL])[:17], 0.0005,
                                               fast_reply([(i, DATA[i]) for i in ALL])[17:]], ALL, 0, 0),
    "fast, last servo silent": (True, [fast_reply([(1, DATA[1]), (2, DATA[2])], declared=[10, 10, 10])],
                                (1, 2), 0, 2),
    # the packet CRC and the last servo's running CRC (the same two bytes) are both wrong
    "fast, corrupted": (True, [_corrupt(fast_reply([(i, DATA[i]) for i in ALL]))], (1, 2), 4, 0),
}


class _Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def __getattr__(self, level: str):
        return lambda message: self.lines.append(f"{level}: {message}")


def _run(script: list, fast: bool, direct_io: bool, leftover: bytes = b"") -> tuple:
    """Two reads of IDs 1-3 answered by ``script``; what the bus decoded and counted."""
    peer = WirePeer(lambda packet: script)
    log = _Log()
    bus = DynamixelBus(peer.path, 1_000_000, **BUS, logger=log, direct_io=direct_io)
    try:
        bus.open()
        if leftover:
            peer.send(leftover)
            time.sleep(0.05)  # let them land in the input before the first instruction goes out
        results = [bus.execute(SyncRead(126, 10, [1, 2, 3], fast, protocol=2)).value for _ in range(2)]
        s = bus.stats
        return results, s.crc_errors, s.discarded_bytes, s.timeouts, s.bytes_rx, s.bytes_tx, log.lines
    finally:
        bus.close()
        peer.close()


@pytest.mark.parametrize("name", list(SCRIPTS))
def test_direct_io_decodes_the_same_replies_as_pyserial(name):
    fast, script, ids, crc_errors, timeouts = SCRIPTS[name]
    direct, plain = _run(script, fast, True), _run(script, fast, False)
    assert direct == plain
    results = direct[0]
    assert results[0] == results[1] == {i: DATA[i] for i in ids}
    assert direct[1] == crc_errors
    assert direct[3] == timeouts


def test_bytes_left_over_are_dropped_and_counted_the_same():
    fast, script = SCRIPTS["clean, one piece"][:2]
    direct, plain = _run(script, fast, True, NOISE * 3), _run(script, fast, False, NOISE * 3)
    assert direct == plain
    assert direct[0][0] == DATA
    assert direct[2] == len(NOISE) * 3


def _vanish_mid_run(direct_io: bool) -> tuple:
    answered: list[bytes] = []

    def once(packet: bytes) -> list:
        answered.append(packet)
        return [b"".join(_replies(1, 2, 3))] if len(answered) == 1 else []
    peer = WirePeer(once)
    log = _Log()
    bus = DynamixelBus(peer.path, 1_000_000, **BUS, logger=log, direct_io=direct_io)
    try:
        bus.open()
        first = bus.execute(SyncRead(126, 10, [1, 2, 3], protocol=2)).value
        read = bus.start_sync_read(126, 10, [1, 2, 3], protocol=2)
        peer.vanish()
        return first, read.result(), bus.is_open, bus.stats.disconnects, [line for line in log.lines if "stopped" in line]
    finally:
        bus.close()
        peer.close()


def test_a_vanished_device_is_reported_the_same():
    direct, plain = _vanish_mid_run(True), _vanish_mid_run(False)
    assert direct[0] == DATA
    assert direct[2:4] == (False, 1)
    assert len(direct[4]) == 1 and "stopped working" in direct[4][0]
    assert direct[1:] == plain[1:]


def _stale_before_a_write(direct_io: bool) -> tuple:
    """A late reply lands while nothing is in flight; a sync write goes out (no reply, no input
    flush of its own), then a sync read: the late reply must be dropped and counted, never taken."""
    stale = status(1, bytes(10))  # the right ID and size for the read below: only the flush tells it apart
    peer = WirePeer(lambda packet: [] if packet[7] == 0x83 else [b"".join(_replies(1, 2, 3))])
    bus = DynamixelBus(peer.path, 1_000_000, **BUS, logger=_Log(), direct_io=direct_io)
    try:
        bus.open()
        peer.send(stale)
        time.sleep(0.05)
        assert bus.execute(bus.prepare_sync_write(116, 4, {1: bytes(4), 2: bytes(4)}, protocol=2)).value
        time.sleep(0.02)  # the write is answered by nothing
        return bus.execute(SyncRead(126, 10, [1, 2, 3], protocol=2)).value, bus.stats.discarded_bytes, len(stale), peer.received
    finally:
        bus.close()
        peer.close()


def test_a_late_reply_before_a_sync_write_is_dropped_by_the_next_read():
    for direct_io in (True, False):
        data, discarded, stale, received = _stale_before_a_write(direct_io)
        assert data == DATA
        assert discarded == stale
        assert [packet[7] for packet in received] == [0x83, 0x82]
