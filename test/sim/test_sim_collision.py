"""Two servos at one ID on the virtual bus collide on the wire as on hardware: both answer, their
replies overlap (wired-AND, the second two byte-times later) or come back to back when their
Return Delay Times are far apart. Driven by the real dynamixel_sdk over the pty."""

from __future__ import annotations

import os
import subprocess
import sys

from dynamixel_sdk import COMM_RX_CORRUPT, COMM_RX_TIMEOUT, COMM_SUCCESS

from dynamixel_handler.protocol import FrameReader
from dynamixel_handler.protocol import servo as p
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler.sim.cli import run_command
from dynamixel_handler.sim.collision import overlap, status_id_2

XM430, XL330 = 1020, 1200
PING_1 = p.build_packet(1, p.PING)


def _ping_reply(model: int, firmware: int) -> bytes:
    return p.build_status(1, 0, bytes([model & 0xFF, model >> 8, firmware]))


def test_a_shared_id_garbles_the_sdk_ping_and_only_that_id(make_bus, make_sdk):
    bus = make_bus([(1, XM430), (1, XM430), (2, XM430)])
    port, ph = make_sdk(bus.path)
    _, result, _ = ph.ping(port, 1)
    assert result in (COMM_RX_CORRUPT, COMM_RX_TIMEOUT)  # bytes came, but no valid packet
    assert ph.ping(port, 2)[:2] == (XM430, COMM_SUCCESS)
    assert len(bus.servos_at(1)) == 2 and bus.servo(1).model.number == XM430


def test_overlapping_replies_are_the_wired_and_of_both(make_bus, make_raw):
    """The second servo starts two byte-times after the first; where both drive the line, a 0 wins."""
    bus = make_bus([(1, XM430), (1, XL330)])
    first = _ping_reply(XM430, bus.servos_at(1)[0].read("firmware_version"))
    second = _ping_reply(XL330, bus.servos_at(1)[1].read("firmware_version"))
    expected = bytearray(first + b"\xff\xff")
    for i, byte in enumerate(second):
        expected[2 + i] &= byte
    got = make_raw(bus.path).exchange(PING_1, len(expected))
    assert got == bytes(expected)
    reader = FrameReader()
    assert reader.frames(got) == []  # no valid packet in them


def test_return_delay_times_far_apart_give_two_replies_back_to_back(make_bus, make_raw, make_sdk):
    """At 1 Mbps a ping reply lasts 140 µs: a servo answering after 0 µs and one after 500 µs do
    not overlap, so one request gets two valid replies; the SDK takes the first."""
    bus = make_bus([(1, XM430), (1, XL330)])
    quick, slow = bus.servos_at(1)
    quick.write("return_delay_time", 0)
    slow.write("return_delay_time", 250)
    got = make_raw(bus.path).exchange(PING_1, 28)
    frames = FrameReader().frames(got)
    assert [p.u16(body, 2) for _, body, _ in frames] == [XM430, XL330]
    port, ph = make_sdk(bus.path)
    assert ph.ping(port, 1)[:2] == (XM430, COMM_SUCCESS)


def test_broadcast_ping_finds_the_others_but_not_the_shared_id(make_bus, make_sdk):
    bus = make_bus([(1, XM430), (1, XM430), (2, XL330), (3, XM430)])
    port, ph = make_sdk(bus.path)
    found, result = ph.broadcastPing(port)
    assert 1 not in found
    assert {2, 3} <= set(found) and found[2][0] == XL330


def test_a_write_to_a_shared_id_reaches_both(make_bus, make_sdk):
    """Set ID cannot separate two servos at one ID: both take the new ID (and still collide)."""
    bus = make_bus([(1, XM430), (1, XM430)])
    port, ph = make_sdk(bus.path)
    ph.write1ByteTxRx(port, 1, 7, 5)  # ID (address 7); the reply collides too
    assert [s.id for s in bus.servos_at(5)] == [5, 5] and bus.servos_at(1) == []


def test_add_collides_only_when_asked(make_bus):
    bus = make_bus({1: XM430}, baudrate=None)  # unboxed: 57600 bps
    assert run_command(bus, "add 1 XM430-W350").startswith("error: ID 1 already answers")
    assert len(bus.servos_at(1)) == 1
    assert "collide" in run_command(bus, "add 1 XL330-M288 --again")
    assert [s.model.number for s in bus.servos_at(1)] == [XM430, XL330]
    for servo in bus.servos_at(1):
        servo.write("baud_rate", 3)  # both at 1 Mbps: a new unboxed one at 57600 meets no one
    assert run_command(bus, "add 1 XM430-W350") == "ok"


def test_a_shared_id_survives_the_state_file(tmp_path):
    state = str(tmp_path / "bus.json")
    bus = VirtualBus([(4, XM430), (4, XL330), (5, XM430)], wire_timing=False, state_file=state)
    bus.save_state()
    again = VirtualBus(state_file=state, wire_timing=False)
    assert [s.model.number for s in again.servos_at(4)] == [XM430, XL330]
    assert [s.id for s in again.all_servos] == [4, 4, 5]


def test_servo_given_twice_on_the_command_line_collides(tmp_path):
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "dynamixel_handler.sim", "--no-wire-timing", "--servo", "3:XM430-W350",
         "--servo", "3:XL330-M288", "--ids", "3,4", "--models", "XC430-W150"],
        input="list\nquit\n", capture_output=True, text=True, timeout=30, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("ID ")]
    assert "ID 3: XM430-W350 (1020) at 57600 bps [shares its ID: collides]" in lines
    assert "ID 3: XL330-M288 (1200) at 57600 bps [shares its ID: collides]" in lines
    assert any(line.startswith("ID 4: XC430-W150") for line in lines)
    assert not any(line.startswith("ID 3: XC430") for line in lines)  # --servo replaces --ids' ID 3


def test_the_line_idles_between_replies_that_do_not_overlap():
    """The wire timing of two replies at one ID, from the instruction's end: the first after its
    Return Delay Time, the second after its own plus two byte-times, the line idle between."""
    a, b = _ping_reply(XM430, 48), _ping_reply(XL330, 52)
    byte_s = 10 / 1_000_000
    chunks = overlap([(0.0, a), (500e-6, b)], 1_000_000, status_id_2)
    assert [reply for _, reply in chunks] == [a, b]
    assert chunks[0][0] == 0.0
    assert abs(chunks[1][0] - (500e-6 + 2 * byte_s - len(a) * byte_s)) < 1e-9
    assert overlap([(250e-6, a), (250e-6, b)], 1_000_000, status_id_2, skew_bytes=0)[0] == \
        (250e-6, bytes(x & y for x, y in zip(a, b)))  # same start: one packet, every byte ANDed
