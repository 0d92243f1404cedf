"""Protocol 2.0 packet rules, checked against the e-Manual's example packets and, for the CRC,
against dynamixel_sdk's own table-driven routine (an independent implementation)."""
from __future__ import annotations

from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler
from hypothesis import given, settings
from hypothesis import strategies as st

from dynamixel_handler.protocol import HEADER, FrameReader, crc16, crc16_bytewise
from dynamixel_handler.protocol import host as p

_SDK = Protocol2PacketHandler()


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=64))
def test_crc_matches_the_sdk_routine(data):
    assert p.crc16(data) == _SDK.updateCRC(0, list(data), len(data))


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300), st.integers(0, 0xFFFF), st.integers(0, 300))
def test_crc_two_bytes_a_step_equals_the_byte_steps(data, start, cut):
    """The word-at-a-time CRC against the byte-at-a-time one and the SDK's: any length (odd ones
    end with a byte step), any starting register (a fast-read reply continues one), any buffer type,
    and an accumulation cut anywhere (odd cuts included) gives the CRC of the whole."""
    want = crc16_bytewise(data, start)
    assert want == _SDK.updateCRC(start, list(data), len(data))
    for form in (data, bytearray(data), memoryview(bytearray(data)), list(data)):
        assert crc16(form, start) == want
    cut = min(cut, len(data))
    assert crc16(memoryview(data)[cut:], crc16(data[:cut], start)) == want


def test_emanual_example_packets():
    # ping ID 1; read present position of ID 1; write goal 512; status of a ping
    assert p.build_instruction(1, p.PING).hex() == "fffffd0001030001194e"
    assert p.build_instruction(1, p.READ, bytes([0x84, 0, 4, 0])).hex() == "fffffd0001070002840004001d15"
    assert p.build_instruction(1, p.WRITE, bytes([0x74, 0, 0, 2, 0, 0])).hex() == \
        "fffffd0001090003740000020000ca89"
    assert p.build_status(1, 0, bytes([6, 4, 0x26])).hex() == "fffffd000107005500060426655d"
    # sync read of IDs 1 and 2 at 132 x 4
    assert p.build_instruction(0xFE, p.SYNC_READ, p.sync_read_params(132, 4, [1, 2])).hex() == \
        "fffffd00fe090082840004000102cefa"


def stuffed_patterns():
    return st.lists(st.sampled_from([b"\xff", b"\xfd", b"\x00", b"\xff\xff\xfd", b"\x12"]), max_size=20).map(b"".join)


@settings(max_examples=200, deadline=None)
@given(stuffed_patterns())
def test_stuffing_round_trips_and_leaves_no_header_pattern(body):
    stuffed = p.stuff(body)
    assert p.unstuff(stuffed) == body
    # after stuffing every FF FF FD is followed by FD: no false header inside a packet
    index = stuffed.find(b"\xff\xff\xfd")
    while index >= 0:
        assert stuffed[index + 3:index + 4] == b"\xfd"
        index = stuffed.find(b"\xff\xff\xfd", index + 4)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 252), st.integers(0, 0xFF), stuffed_patterns())
def test_length_and_crc_cover_the_stuffed_bytes(dxl_id, instruction, params):
    packet = p.build_instruction(dxl_id, instruction, params)
    length = packet[5] | (packet[6] << 8)
    assert len(packet) == 7 + length
    assert packet[-2] | (packet[-1] << 8) == _SDK.updateCRC(0, list(packet[:-2]), len(packet) - 2)
    assert p.unstuff(packet[7:-2]) == bytes([instruction]) + params


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 252), stuffed_patterns()), max_size=5), st.integers(1, 7))
def test_status_stream_survives_any_chunking_and_noise(replies, chunk):
    wire = b"\x00\xff\xfd" + b"".join(p.build_status(i, 0, d) + b"\xff" for i, d in replies)
    stream = p.StatusStream()
    out = []
    for start in range(0, len(wire), chunk):
        out += stream.feed(wire[start:start + chunk])
    assert [(s.dxl_id, s.params) for s in out] == [(i, d) for i, d in replies]


def test_status_stream_drops_bad_crc_and_instruction_echo():
    good = p.build_status(2, 0, b"\x10")
    bad = bytearray(p.build_status(1, 0, b"\x20"))
    bad[-1] ^= 1
    echo = p.build_instruction(1, p.READ, bytes([146, 0, 1, 0]))
    stream = p.StatusStream()
    assert stream.feed(echo + bytes(bad) + good) == [p.Status(2, 0, b"\x10")]
    assert stream.crc_errors == 1


def emanual_fast_sync_reply() -> bytes:
    # e-Manual Fast Sync Read example: IDs 3, 7, 4, present position 166, 2079, 1023
    return bytes.fromhex("fffffd00fe19005500" "03a6000000" "8408" "00071f080000" "16ca" "0004ff030000" "d19e")


def test_fast_reply_parses_the_emanual_example():
    reply = p.FastReply([(3, 4), (7, 4), (4, 4)])
    reply.feed(emanual_fast_sync_reply())
    assert reply.complete
    got = reply.segments()
    assert {i: int.from_bytes(s.params, "little") for i, s in got.items()} == {3: 166, 7: 2079, 4: 1023}


def test_fast_reply_salvages_segments_before_a_corrupted_one():
    wire = bytearray(emanual_fast_sync_reply())
    wire[-4] ^= 0x01  # corrupt ID 4's data: packet CRC fails, running CRCs of 3 and 7 still hold
    reply = p.FastReply([(3, 4), (7, 4), (4, 4)])
    reply.feed(bytes(wire))
    assert sorted(reply.segments()) == [3, 7]
    assert reply.crc_errors >= 1


def test_fast_reply_skips_a_silent_servo_in_the_middle():
    # ID 7 silent: ID 4 follows ID 3 directly, its CRC running over what was on the wire
    head = bytes.fromhex("fffffd00fe19005500" "03a6000000")
    wire = head + p.u16(p.crc16(head))
    wire += bytes.fromhex("0004ff030000")
    wire += p.u16(p.crc16(wire))
    reply = p.FastReply([(3, 4), (7, 4), (4, 4)])
    reply.feed(wire)
    assert not reply.complete
    assert {i: int.from_bytes(s.params, "little") for i, s in reply.segments().items()} == {3: 166, 4: 1023}


class _ByteAtATimeReader:
    """The packet reader as it was first written (header search, one packet cut off the buffer at a
    time): the reference the offset-based ``FrameReader`` must agree with."""

    def __init__(self, min_length: int) -> None:
        self.min_length, self.crc_errors, self.discarded_bytes, self.buf = min_length, 0, 0, bytearray()

    def frames(self, data: bytes) -> list[tuple[int, bytes, int]]:
        buf = self.buf
        buf += data
        out = []
        while True:
            start = buf.find(HEADER)
            if start < 0:
                keep = next((k for k in (3, 2, 1) if len(buf) >= k and buf[-k:] == HEADER[:k]), 0)
                self.discarded_bytes += len(buf) - keep
                del buf[: len(buf) - keep]
                return out
            self.discarded_bytes += start
            del buf[:start]
            if len(buf) < 7:
                return out
            packet_id, length = buf[4], buf[5] | (buf[6] << 8)
            if packet_id in (0xFD, 0xFF) or length < self.min_length or length > 4096:
                self.discarded_bytes += 1
                del buf[:1]
                continue
            total = 7 + length
            if len(buf) < total:
                return out
            if crc16_bytewise(buf[: total - 2]) != buf[total - 2] | (buf[total - 1] << 8):
                self.crc_errors += 1
                self.discarded_bytes += 1
                del buf[:1]
                continue
            out.append((packet_id, p.unstuff(bytes(buf[7: total - 2])), total))
            del buf[:total]


_pieces = st.one_of(
    st.builds(lambda i, body: p.build_status(i, 0, body), st.integers(0, 252),
              st.binary(max_size=12) | st.just(b"\xff\xff\xfd\x00\xff\xff\xfd")),
    st.builds(lambda i, body: p.build_instruction(i, 0x03, body), st.integers(0, 252), st.binary(max_size=8)),
    st.builds(lambda i, cut: p.build_status(i, 0, b"\x01\x02\x03")[:cut], st.integers(0, 252), st.integers(1, 12)),
    st.builds(lambda i, k: (lambda pk: pk[:k] + bytes([pk[k] ^ 0x55]) + pk[k + 1:])(p.build_status(i, 0, b"\x07\x08")),
              st.integers(0, 252), st.integers(4, 12)),
    st.binary(max_size=6), st.just(HEADER), st.just(HEADER[:3]), st.just(b"\xff\xff\xfd\x00\xfd"),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_pieces, max_size=12), st.lists(st.integers(1, 40), min_size=1, max_size=20), st.sampled_from([3, 4]))
def test_the_packet_reader_equals_the_byte_at_a_time_reader_on_any_stream(pieces, cuts, min_length):
    """Packets, noise, lone and partial headers, truncated and corrupted packets, fed in arbitrary
    chunks: the same packets, CRC error and discarded byte counts, and bytes held, as the reference."""
    stream = b"".join(pieces)
    reader, reference = FrameReader(min_length), _ByteAtATimeReader(min_length)
    pos, k = 0, 0
    while pos < len(stream):
        chunk = stream[pos: pos + cuts[k % len(cuts)]]
        pos, k = pos + len(chunk), k + 1
        assert reader.frames(chunk) == reference.frames(chunk)
        assert (reader.crc_errors, reader.discarded_bytes, reader.pending_bytes) == \
               (reference.crc_errors, reference.discarded_bytes, len(reference.buf))
