"""The bus layer on a real pseudo-terminal, against a scripted peer.

Each test puts a tiny "servo" on the far end of a pty: it records the exact bytes our
bus sends and answers with bytes built here (CRC from dynamixel_sdk's own routine, an
independent oracle). This is the clearest way to show, byte for byte, that the
dynamixel_sdk 4.1.0 defects do not reach users:

1. stuffing of FF FF FD in instruction packets     -> test_goal_with_ff_ff_fd_is_stuffed...
2. fast bulk/sync read parse when IDs equal data   -> test_fast_bulk_read_..., test_fast_sync_read_...
3. action's status reply left in the input         -> test_unicast_action_consumes..., test_stale_reply...
4. one silent servo emptying a sync read           -> test_sync_read_keeps_servos_that_answered...
5. busy-polling while waiting                      -> test_waiting_for_a_silent_servo_does_not_spin
6. hard-coded 16 ms latency in timeouts            -> test_timeout_follows_configured_latency_timer
"""
from __future__ import annotations

import resource
import time

import pytest

from dynamixel_handler.bus import BusError, DynamixelBus
from dynamixel_handler.bus.ops import Action, BulkRead, Ping, Read, SyncRead, Write
from dynamixel_handler.bus.port import explain_open_error
from dynamixel_handler.bus.result import Failure

from support.wire_peer import WirePeer, sdk_crc, status, with_crc


def fast_reply(segments: list[tuple[int, bytes]], declared: list[int] | None = None) -> bytes:
    """A fast sync/bulk read reply per the e-Manual: one header, then ERR ID data CRC per servo,
    each CRC being the running CRC of everything before it. ``declared`` = data sizes the
    header's length announces (defaults to the segments sent)."""
    sizes = declared if declared is not None else [len(d) for _, d in segments]
    length = 1 + sum(size + 4 for size in sizes)
    packet = bytes([0xFF, 0xFF, 0xFD, 0x00, 0xFE, length & 0xFF, length >> 8, 0x55])
    for dxl_id, data in segments:
        packet = with_crc(packet + bytes([0x00, dxl_id]) + data)
    return packet



@pytest.fixture
def peer():
    made = []

    def make(handler=None) -> WirePeer:
        made.append(WirePeer(handler))
        return made[-1]

    yield make
    for item in made:
        item.close()


def open_bus(path: str, **kwargs) -> DynamixelBus:
    bus = DynamixelBus(path, **kwargs)
    bus.open()
    return bus


# ---------------------------------------------------------------- defect 1: byte stuffing
def test_goal_with_ff_ff_fd_is_stuffed_on_the_wire(peer):
    """A P-series goal of -131073 pulses is FF FF FD FF little endian: it must go out stuffed."""
    far = peer(lambda packet: [status(1)])
    bus = open_bus(far.path)
    assert bus.execute(Write(1, 564, (-131073).to_bytes(4, "little", signed=True), protocol=2)).value is True

    sent = far.received[0]
    body = bytes([0x03, 0x34, 0x02, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF])  # INST, addr, stuffed data
    assert sent[:7] == bytes([0xFF, 0xFF, 0xFD, 0x00, 0x01, len(body) + 2, 0x00])
    assert sent[7:-2] == body
    assert sent[-2] | (sent[-1] << 8) == sdk_crc(sent[:-2])  # CRC over the stuffed bytes
    bus.close()


def test_sync_write_data_is_stuffed_and_length_counts_the_stuffing(peer):
    far = peer()
    bus = open_bus(far.path)
    goal = (-131073).to_bytes(4, "little", signed=True)
    assert bus.execute(bus.prepare_sync_write(564, 4, {1: goal, 2: goal}, protocol=2)).value is True
    time.sleep(0.05)
    sent = far.received[0]
    params = bytes([0x34, 0x02, 0x04, 0x00, 1, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF, 2, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF])
    assert sent[4] == 0xFE and sent[7] == 0x83
    assert sent[8:-2] == params
    assert sent[5] | (sent[6] << 8) == len(params) + 3
    assert sent[-2] | (sent[-1] << 8) == sdk_crc(sent[:-2])
    bus.close()


# ---------------------------------------------------------------- defect 2: fast read parsing
def test_fast_bulk_read_ids_equal_to_address_and_length_bytes(peer):
    """ID 4 equals the first servo's length byte (4) and ID 1 its data: parse stays positional."""
    data_1 = bytes([0x04, 0x01, 0x04, 0x00])
    data_4 = bytes([0x01])

    def answer(packet):
        if packet[7] == 0x9A:
            return [fast_reply([(1, data_1), (4, data_4)])]
        return []

    far = peer(answer)
    bus = open_bus(far.path)
    got = bus.execute(BulkRead({1: (132, 4), 4: (146, 1)}, fast=True, protocol=2)).value
    assert got == {1: data_1, 4: data_4}
    assert far.received[0][8:-2] == bytes([1, 132, 0, 4, 0, 4, 146, 0, 1, 0])
    assert bus.stats.full_successes == 1
    bus.close()


def test_fast_sync_read_data_bytes_equal_to_ids(peer):
    """e-Manual order 3, 7, 4 with data containing 7, 4 and 3: each servo keeps its own data."""
    data = {3: bytes([7, 4, 3, 0]), 7: bytes([3, 3, 7, 0]), 4: bytes([0xFF, 0xFF, 0xFD, 0x00])}

    def answer(packet):
        return [fast_reply([(i, data[i]) for i in (3, 7, 4)])] if packet[7] == 0x8A else []

    far = peer(answer)
    bus = open_bus(far.path)
    assert bus.execute(SyncRead(132, 4, [3, 7, 4], fast=True, protocol=2)).value == data
    bus.close()


def test_fast_sync_read_with_silent_last_servo_keeps_the_others(peer):
    data = {1: bytes([1, 2, 3, 4]), 2: bytes([5, 6, 7, 8])}

    def answer(packet):
        # the header announces three servos; the third never sends its segment
        return [fast_reply([(1, data[1]), (2, data[2])], declared=[4, 4, 4])] if packet[7] == 0x8A else []

    far = peer(answer)
    bus = open_bus(far.path, retry_num=0)
    assert bus.execute(SyncRead(132, 4, [1, 2, 3], fast=True, protocol=2)).value == data
    assert bus.stats.successes == 1 and bus.stats.full_successes == 0
    bus.close()


# ---------------------------------------------------------------- defect 3: stray replies
def test_unicast_action_consumes_its_reply_so_the_next_read_is_right(peer):
    position = (2048).to_bytes(4, "little")

    def answer(packet):
        if packet[7] == 0x05:
            return [0.01, status(1)]  # the action's status comes a little late
        if packet[7] == 0x02:
            return [status(1, position)]
        return []

    far = peer(answer)
    bus = open_bus(far.path)
    assert bus.execute(Action(1, protocol=2)).value is True
    assert bus.execute(Read(1, 132, 4, protocol=2)).value == position
    assert [packet[7] for packet in far.received] == [0x05, 0x02]
    bus.close()


def test_broadcast_action_waits_for_nothing(peer):
    far = peer()
    bus = open_bus(far.path)
    assert bus.execute(Action(protocol=2)).value is True
    time.sleep(0.05)
    assert far.received[0][4] == 0xFE and far.received[0][7] == 0x05
    bus.close()


def test_stale_reply_and_noise_never_become_the_answer(peer):
    """A late status from an earlier instruction (same ID, no data) and line noise precede the
    real reply: the read returns the real data."""
    position = (1234).to_bytes(4, "little")
    far = peer(lambda packet: [status(1) + b"\x00\xff\x13" + status(1, position)])
    bus = open_bus(far.path)
    assert bus.execute(Read(1, 132, 4, protocol=2)).value == position
    assert bus.stats.discarded_bytes > 0
    bus.close()


def test_a_late_reply_to_one_read_is_never_taken_for_the_next_read_of_the_same_servo(peer):
    """A status names no address: a reply to a read of PWM Limit (2 bytes) that comes after its
    timeout would pass for the reply to the next read of Current Limit (2 bytes) from the same
    servo. The bus waits such a reply out before it asks that servo something else."""
    def answer(packet):
        address = packet[8] | (packet[9] << 8)
        if address == 36:
            return [0.05, status(1, (885).to_bytes(2, "little"))]  # after the bus gave up on it
        return [status(1, (1193).to_bytes(2, "little"))]
    far = peer(answer)
    bus = open_bus(far.path, latency_timer_ms=16.0, retry_num=0)
    first = bus.execute(Read(1, 36, 2, protocol=2))
    assert first.value is None and first.failure is Failure.NO_REPLY and bus.timing.last_timeout_ms < 50
    assert bus.execute(Read(1, 38, 2, protocol=2)).value == (1193).to_bytes(2, "little")
    bus.close()


def test_bytes_left_from_before_are_flushed_before_sending(peer):
    position = (77).to_bytes(4, "little")
    far = peer(lambda packet: [status(1, position)] if packet[7] == 0x02 else [])
    bus = open_bus(far.path)
    far.send(status(1, (999).to_bytes(4, "little")))  # unsolicited, earlier than our instruction
    time.sleep(0.05)
    assert bus.execute(Read(1, 132, 4, protocol=2)).value == position
    bus.close()


# ---------------------------------------------------------------- defect 4: silent servo in sync read
@pytest.mark.parametrize("silent", [1, 2, 3])
def test_sync_read_keeps_servos_that_answered(peer, silent):
    values = {i: (1000 * i).to_bytes(4, "little") for i in (1, 2, 3)}

    def answer(packet):
        if packet[7] != 0x82:
            return []
        return [status(i, values[i]) for i in packet[12:-2] if i != silent]

    far = peer(answer)
    bus = open_bus(far.path)
    got = bus.execute(SyncRead(132, 4, [1, 2, 3], protocol=2)).value
    assert got == {i: values[i] for i in (1, 2, 3) if i != silent}
    assert bus.stats.packets_sent == 1  # partial answers are not retried
    assert (bus.stats.successes, bus.stats.full_successes) == (1, 0)
    bus.close()


def test_sync_read_retries_when_nobody_answered(peer):
    calls = []

    def answer(packet):
        calls.append(packet)
        return [status(1, b"\x05")] if len(calls) >= 3 else []

    far = peer(answer)
    bus = open_bus(far.path, retry_num=5, retry_interval_ms=1.0)
    assert bus.execute(SyncRead(146, 1, [1], protocol=2)).value == {1: b"\x05"}
    assert bus.stats.retries == 2
    bus.close()


# ---------------------------------------------------------------- defect 5: no busy polling
def test_waiting_for_a_silent_servo_does_not_spin(peer):
    far = peer()
    bus = open_bus(far.path, latency_timer_ms=200.0, retry_num=0)
    wall0 = time.monotonic()
    cpu0 = resource.getrusage(resource.RUSAGE_THREAD)
    assert bus.execute(Ping(9, protocol=2)).value is None
    cpu1 = resource.getrusage(resource.RUSAGE_THREAD)
    wall = time.monotonic() - wall0
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    assert wall > 0.3  # we really waited for the silent servo
    assert cpu < 0.3 * wall
    bus.close()


# ---------------------------------------------------------------- defect 6: latency timer
def test_timeout_follows_configured_latency_timer(peer):
    far = peer()
    bus = open_bus(far.path, baudrate=1000000, latency_timer_ms=1.0, retry_num=0)
    assert bus.execute(Ping(9, protocol=2)).value is None
    ping_bytes = 10 + 14  # instruction + reply
    assert bus.timing.last_timeout_ms == pytest.approx(2 * 1.0 + ping_bytes * 0.01 + bus.timing.timeout_margin_ms)
    assert bus.timing.last_timeout_ms < 2 * 16 + 2  # the SDK's floor for any adapter
    slow = DynamixelBus(far.path, baudrate=1000000, latency_timer_ms=16.0)
    assert slow.timing.reply_timeout_ms(10, 14) == pytest.approx(32 + 0.24 + slow.timing.timeout_margin_ms)
    bus.close()


# ---------------------------------------------------------------- everyday behaviour
def test_ping_scan_and_firmware(peer):
    models = {1: 1020, 3: 2020, 7: 54024}

    def answer(packet):
        if packet[7] != 0x01:
            return []
        ids = sorted(models) if packet[4] == 0xFE else [packet[4]] if packet[4] in models else []
        return [status(i, models[i].to_bytes(2, "little") + b"\x2d") for i in ids]

    far = peer(answer)
    bus = open_bus(far.path)
    assert bus.execute(Ping(3, protocol=2)).value == 2020
    assert bus.execute(Ping(4, retries=0, protocol=2)).value is None
    assert bus.scan(range(0, 20)) == models
    assert far.received[-1][4] == 0xFE  # one broadcast ping for the wide range
    assert bus.scan([1, 2]) == {1: 1020}  # narrow range: unicast
    assert bus.firmware_versions[7] == 0x2D
    bus.close()


def test_scan_falls_back_to_unicast_when_broadcast_replies_collide(peer):
    def answer(packet):
        if packet[4] == 0xFE:
            garbled = bytearray(status(2, (1020).to_bytes(2, "little") + b"\x2d"))
            garbled[9] ^= 0xFF
            return [status(1, (1020).to_bytes(2, "little") + b"\x2d") + bytes(garbled)]
        if packet[4] in (1, 2):
            return [status(packet[4], (1020).to_bytes(2, "little") + b"\x2d")]
        return []

    far = peer(answer)
    bus = open_bus(far.path, latency_timer_ms=2.0)
    assert bus.scan(range(0, 6)) == {1: 1020, 2: 1020}
    assert bus.stats.crc_errors >= 1
    bus.close()


def test_retries_then_success_and_servo_errors(peer):
    attempts = []

    def answer(packet):
        if packet[7] == 0x02:
            attempts.append(packet)
            return [status(1, b"\x2a\x00", error=0x80)] if len(attempts) > 2 else []
        if packet[7] == 0x03:
            return [status(1, error=0x06)]  # data limit error
        return []

    far = peer(answer)
    bus = open_bus(far.path, retry_num=5, retry_interval_ms=1.0)
    got = bus.execute(Read(1, 126, 2, protocol=2))
    assert got.value == b"\x2a\x00" and got.error == 0x80  # alert bit alone: data still valid
    assert bus.stats.retries == 2
    sent_before = bus.stats.packets_sent
    refused = bus.execute(Write(1, 116, b"\x00\x00\x00\x00", protocol=2))
    assert refused.value is False and refused.failure is Failure.REFUSED
    assert bus.stats.packets_sent == sent_before + 1  # a refusal is not retried
    assert refused.error == 0x06 and "limit" in refused.why
    assert bus.stats.servo_errors == 1
    bus.close()


def test_stats_count_bytes_and_success(peer):
    far = peer(lambda packet: [status(packet[4], b"\x01")] if packet[7] == 0x02 else [])
    bus = open_bus(far.path)
    bus.execute(Read(1, 146, 1, protocol=2)).value
    assert bus.stats.transactions == 1 and bus.stats.success_rate == 1.0
    assert bus.stats.bytes_tx == 14 and bus.stats.bytes_rx == 12
    bus.close()


# ---------------------------------------------------------------- opening and vanishing
def test_missing_device_is_a_clear_error(tmp_path):
    with pytest.raises(BusError, match="does not exist: is the adapter plugged in"):
        DynamixelBus(str(tmp_path / "ttyUSB9")).open()


def test_busy_device_is_a_clear_error(peer):
    far = peer()
    first = open_bus(far.path)
    with pytest.raises(BusError, match="busy"):
        DynamixelBus(far.path).open()
    first.close()


def test_not_a_tty_is_a_clear_error(tmp_path):
    plain = tmp_path / "notaport"
    plain.write_text("")
    with pytest.raises(BusError, match="not a serial port"):
        DynamixelBus(str(plain)).open()


def test_unsupported_baudrate_is_a_clear_error(peer):
    far = peer()
    with pytest.raises(BusError, match="not a Dynamixel baud rate"):
        DynamixelBus(far.path, baudrate=12345).open()


def test_permission_denied_mentions_dialout():
    text = explain_open_error("/dev/ttyUSB0", PermissionError(13, "Permission denied"))
    assert "dialout" in text and "/dev/ttyUSB0" in text


def test_device_vanishing_mid_run_then_reopen(peer, tmp_path):
    link = tmp_path / "ttyDXL"
    answer = lambda packet: [status(packet[4], b"\x21")] if packet[7] == 0x02 else []  # noqa: E731
    far = peer(answer)
    link.symlink_to(far.path)
    bus = open_bus(str(link))
    assert bus.execute(Read(1, 146, 1, protocol=2)).value == b"\x21"

    far.vanish()
    link.unlink()
    assert bus.execute(Read(1, 146, 1, protocol=2)).value is None  # no exception escapes
    assert bus.execute(SyncRead(146, 1, [1, 2], protocol=2)).value == {}
    assert bus.execute(Write(1, 64, b"\x01", protocol=2)).value is False
    assert not bus.is_open and bus.stats.disconnects == 1
    with pytest.raises(BusError, match="does not exist"):
        bus.reopen()

    back = peer(answer)
    link.symlink_to(back.path)
    bus.reopen()
    assert bus.is_open
    assert bus.execute(Read(1, 146, 1, protocol=2)).value == b"\x21"
    bus.close()


def test_stats_delta_gives_the_rates_of_one_period(peer):
    far = peer(lambda packet: [status(1, b"\x01")])  # only ID 1 exists
    bus = open_bus(far.path, retry_num=0)
    bus.execute(Read(1, 146, 1, protocol=2)).value
    before = bus.stats.copy()
    bus.execute(Read(1, 146, 1, protocol=2)).value
    bus.execute(SyncRead(146, 1, [1, 2], protocol=2)).value
    period = bus.stats.delta(before)
    assert period.transactions == 2
    assert period.success_rate == 1.0 and period.full_success_rate == 0.5
    bus.close()


def test_a_read_never_sleeps_blindly_past_the_time_its_replies_are_due():
    """A read that has some of its replies sleeps through the wire time of the rest, but replies
    that are already overdue (an adapter or servos that buffer and then send in a burst) are
    waited for on the port instead, so they are taken the moment they arrive."""
    from dynamixel_handler.bus.port import SLEEP_SLACK_S, blind_sleep_s

    byte_s = 10 / 1_000_000
    # 42 bytes still to come, all due in 10 ms: sleep through their wire time (less the slack)
    assert blind_sleep_s(42, byte_s, now=100.0, due=100.010) == pytest.approx(42 * byte_s - SLEEP_SLACK_S)
    # due in 0.35 ms: sleep no longer than until shortly before then
    assert blind_sleep_s(42, byte_s, now=100.0, due=100.00035) == pytest.approx(0.00035 - SLEEP_SLACK_S)
    # already overdue: no blind sleep at all
    assert blind_sleep_s(42, byte_s, now=100.0, due=99.9999) <= 0
    assert blind_sleep_s(1000, byte_s, now=100.0, due=100.0) <= 0
    # with nothing known about when they are due: the wire time alone
    assert blind_sleep_s(1000, byte_s, now=100.0) == pytest.approx(1000 * byte_s - SLEEP_SLACK_S)
