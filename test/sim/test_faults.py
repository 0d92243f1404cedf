"""Fault injection as a host sees it through the real dynamixel_sdk, plus the instruction log."""

import os
import subprocess
import sys

from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS

from dynamixel_handler.protocol import servo as p

from support.sdk import PatientPort

XM430 = 1020


def test_silent_id_stops_answering_and_comes_back(make_bus, make_sdk):
    bus = make_bus({1: XM430, 2: XM430})
    port, ph = make_sdk(bus.path)
    bus.set_silent(2)
    assert ph.ping(port, 2)[1] == COMM_RX_TIMEOUT
    assert ph.ping(port, 1)[1] == COMM_SUCCESS
    bus.set_silent(2, False)
    assert ph.ping(port, 2)[1] == COMM_SUCCESS


def test_crc_corruption_is_reported_as_corrupt(make_bus, make_sdk):
    bus = make_bus({1: XM430}, seed=1)
    port, ph = make_sdk(bus.path)
    bus.crc_error_rate = 1.0
    assert ph.ping(port, 1)[1] not in (COMM_SUCCESS, COMM_RX_TIMEOUT)
    bus.crc_error_rate = 0.0
    assert ph.ping(port, 1)[1] == COMM_SUCCESS


def test_garbage_before_a_reply_is_skipped_by_the_host(make_bus, make_sdk):
    bus = make_bus({1: XM430}, seed=2)
    port, ph = make_sdk(bus.path)
    bus.inject_garbage(25)
    assert ph.read4ByteTxRx(port, 1, 0)[1:] == (COMM_SUCCESS, 0)


def test_truncated_reply(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    bus.truncate_next(1)
    assert ph.ping(port, 1)[1] != COMM_SUCCESS
    assert ph.ping(port, 1)[1] == COMM_SUCCESS


def test_hardware_error_sets_alert_bit(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    bus.set_hardware_error(1, 0x01)  # input voltage, not in the default shutdown mask
    model, result, error = ph.ping(port, 1)
    assert result == COMM_SUCCESS and error & p.ALERT_BIT
    assert ph.read1ByteTxRx(port, 1, 70) == (0x01, COMM_SUCCESS, p.ALERT_BIT)


def test_bad_crc_instruction_gets_no_reply_and_garbage_is_resynced(make_bus, make_raw):
    bus = make_bus({1: XM430})
    raw = make_raw(bus.path)
    bad = bytearray(p.build_packet(1, p.PING))
    bad[-1] ^= 0x01
    assert raw.exchange(bytes(bad), 1, 0.1) == b""
    reply = raw.exchange(b"\x00\x13\xff\xff\xfd" + p.build_packet(1, p.PING), 14)
    assert reply == p.build_status(1, 0, bytes([0xFC, 0x03, 48]))
    assert raw.exchange(p.build_packet(1, 0x77), 11) == p.build_status(1, p.ERR_INSTRUCTION)


def test_vanish_and_reappear_with_a_link(make_bus, make_sdk, tmp_path):
    link = str(tmp_path / "ttyDXL")
    bus = make_bus({1: XM430}, link=link)
    assert bus.path == link and os.path.islink(link)
    first = os.readlink(link)
    port, ph = make_sdk(link)
    assert ph.ping(port, 1)[1] == COMM_SUCCESS
    bus.vanish()
    assert not os.path.exists(link)
    try:
        result = ph.ping(port, 1)[1]
    except Exception:  # pyserial reports the unplugged device as an exception
        result = None
    assert result != COMM_SUCCESS
    assert bus.reappear() == link and os.readlink(link) != first
    port2 = PatientPort(link)
    assert port2.openPort()
    try:
        assert ph.ping(port2, 1)[1] == COMM_SUCCESS
    finally:
        port2.closePort()


def test_log_records_instructions(make_bus, make_sdk):
    bus = make_bus({1: XM430})
    port, ph = make_sdk(bus.path)
    bus.clear_log()
    ph.write4ByteTxRx(port, 1, 116, 2000)
    ph.read4ByteTxRx(port, 1, 132)
    entries = [(e.name, e.ids, e.address, e.length) for e in bus.log]
    assert entries == [("write", (1,), 116, 4), ("read", (1,), 132, 4)]
    assert bus.log[0].params == bytes([116, 0]) + (2000).to_bytes(4, "little")


def test_cli_serves_the_default_bus_and_takes_runtime_commands(make_sdk, tmp_path):
    link = str(tmp_path / "dxl")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--link", link, "--quiet"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout.readline().strip() == link
        port, ph = make_sdk(link, 57600)  # unboxed servos: 57600 bps
        assert [ph.ping(port, i)[0] for i in (1, 2, 3, 4)] == [1020, 1120, 2020, 54024]
        proc.stdin.write("silent 3\n")
        proc.stdin.flush()
        for _ in range(50):  # the command is applied asynchronously; poll by pinging
            if ph.ping(port, 3)[1] == COMM_RX_TIMEOUT:
                break
        assert ph.ping(port, 3)[1] == COMM_RX_TIMEOUT
        proc.terminate()
        assert proc.wait(timeout=5) == 0
        assert not os.path.exists(link)
    finally:
        if proc.poll() is None:
            proc.kill()
