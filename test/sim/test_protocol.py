"""Framing rules of Protocol 2.0 as the simulator applies them (no pty involved)."""

from hypothesis import given
from hypothesis import strategies as st

from dynamixel_handler.protocol import servo as p


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def test_crc_matches_emanual_ping_example():
    assert p.build_packet(1, p.PING) == h("FF FF FD 00 01 03 00 01 19 4E")
    assert p.build_status(1, 0, h("06 04 26")) == h("FF FF FD 00 01 07 00 55 00 06 04 26 65 5D")


def test_stuffing_inserts_fd_after_header_pattern():
    assert p.stuff(h("FF FF FD 00")) == h("FF FF FD FD 00")
    assert p.stuff(h("FF FF FF FD")) == h("FF FF FF FD FD")
    assert p.unstuff(h("FF FF FD FD 00")) == h("FF FF FD 00")


@given(st.binary(max_size=64))
def test_stuffing_round_trips_and_never_leaves_a_header(body):
    stuffed = p.stuff(body)
    assert p.unstuff(stuffed) == body
    assert p.HEADER not in stuffed
    packet = p.build_status(7, 0, body)
    parsed = p.PacketParser().feed(packet)
    assert parsed and parsed[0].params == bytes([0]) + body  # error byte, then the data


def test_parser_resyncs_after_garbage_and_skips_bad_crc():
    good = p.build_packet(2, p.READ, h("84 00 04 00"))
    bad = bytearray(p.build_packet(3, p.PING))
    bad[-1] ^= 0xFF
    parser = p.PacketParser()
    stream = h("00 FF FF FD 00 FF 13 37") + bytes(bad) + h("FF FF") + good
    packets = parser.feed(stream[:9]) + parser.feed(stream[9:])
    assert [(pk.packet_id, pk.instruction, pk.params) for pk in packets] == [(2, p.READ, h("84 00 04 00"))]
    assert parser.crc_errors == 1


def test_parser_ignores_implausible_length():
    parser = p.PacketParser()
    assert parser.feed(h("FF FF FD 00 01 FF FF")) == []  # LEN 65535: garbage, not a packet
    assert [pk.packet_id for pk in parser.feed(p.build_packet(1, p.PING))] == [1]


def test_fast_sync_read_reply_matches_emanual_example():
    reply = p.build_fast_status([(0, 3, h("A6 00 00 00")), (0, 7, h("1F 08 00 00")), (0, 4, h("FF 03 00 00"))],
                                3 * (4 + 4))
    assert reply == h("FF FF FD 00 FE 19 00 55 00 03 A6 00 00 00 84 08"
                      "00 07 1F 08 00 00 16 CA 00 04 FF 03 00 00 D1 9E")


def test_fast_bulk_read_reply_matches_emanual_example():
    reply = p.build_fast_status([(0, 3, h("A6 00 00 00")), (0, 7, h("A5 01")), (0, 4, h("1F"))],
                                (4 + 4) + (4 + 2) + (4 + 1))
    assert reply == h("FF FF FD 00 FE 14 00 55 00 03 A6 00 00 00 67 A4 00 07 A5 01 24 74 00 04 1F D9 C1")
