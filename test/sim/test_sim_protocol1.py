"""A Protocol 1.0 servo (AX-12A) on the virtual bus: it answers only Protocol 1.0 packets, at its
own baud rate (2,000,000 / (value + 1) bps), and the Protocol 2.0 servos ignore those packets.
The host is the real dynamixel_sdk (PacketHandler(1.0) and (2.0)) over the pty."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS, PacketHandler

from dynamixel_handler.control_table import known_models, model_by_number
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler.sim.protocol1 import build_instruction1

from support.sdk import PatientPort

AX12A, XM430 = 12, 1020
UNBOXED = {"baudrate": None, "wire_timing": False}  # factory baud rates: AX 1 Mbps, XM 57600


@pytest.fixture
def sdk1(make_sdk):
    """Factory: sdk1(path, bps) -> (port, PacketHandler(1.0), PacketHandler(2.0))."""
    def factory(path: str, bps: int = 1_000_000):
        port, ph2 = make_sdk(path, bps)
        return port, PacketHandler(1.0), ph2
    return factory


def test_protocol1_ping_finds_the_ax12a_and_reads_its_eeprom(make_bus, sdk1):
    bus = make_bus({7: AX12A}, **UNBOXED)
    port, ph1, _ = sdk1(bus.path)
    assert ph1.ping(port, 7) == (AX12A, COMM_SUCCESS, 0)   # ping, then Model Number (address 0)
    assert ph1.read1ByteTxRx(port, 7, 3)[:2] == (7, COMM_SUCCESS)       # ID
    assert ph1.read1ByteTxRx(port, 7, 4)[:2] == (1, COMM_SUCCESS)       # Baud Rate: 1 Mbps
    assert ph1.read1ByteTxRx(port, 7, 2)[:2] == (24, COMM_SUCCESS)      # Firmware Version
    assert ph1.read2ByteTxRx(port, 7, 8)[:2] == (1023, COMM_SUCCESS)    # CCW Angle Limit
    assert ph1.ping(port, 8)[1] == COMM_RX_TIMEOUT


def test_each_protocol_hears_only_its_own_servos(make_bus, sdk1):
    bus = make_bus({7: AX12A, 1: XM430}, baudrate=1_000_000, wire_timing=False)
    port, ph1, ph2 = sdk1(bus.path)
    assert ph2.ping(port, 7)[1] == COMM_RX_TIMEOUT      # the AX ignores Protocol 2.0
    assert ph1.ping(port, 1)[1] == COMM_RX_TIMEOUT      # the XM ignores Protocol 1.0
    assert ph2.ping(port, 1)[:2] == (XM430, COMM_SUCCESS)
    assert 7 not in ph2.broadcastPing(port)[0]
    assert ph1.ping(port, 7)[:2] == (AX12A, COMM_SUCCESS)


@pytest.mark.parametrize("value, found_at, not_at", [
    (34, 57600, (1_000_000, 115200)), (207, 9600, (57600,)), (16, 115200, (57600,))])
def test_the_ax_answers_at_its_own_baud_rate_only(make_bus, sdk1, value, found_at, not_at):
    """Baud Rate value v runs at 2,000,000 / (v + 1): 34 is 57,143 bps (0.8 % off 57600), 16 is
    117,647 (2.1 % off 115200), both within the 3 % a UART takes."""
    bus = make_bus({7: AX12A}, **UNBOXED)
    bus.servos_at(7)[0].write("baud_rate", value)
    for bps in not_at:
        port, ph1, _ = sdk1(bus.path, bps)
        assert ph1.ping(port, 7)[1] == COMM_RX_TIMEOUT
        port.closePort()
    port, ph1, _ = sdk1(bus.path, found_at)
    assert ph1.ping(port, 7)[:2] == (AX12A, COMM_SUCCESS)


def test_a_written_baud_rate_is_answered_at_the_old_one_then_heard_at_the_new(make_bus, sdk1):
    bus = make_bus({7: AX12A}, **UNBOXED)
    port, ph1, _ = sdk1(bus.path)
    assert ph1.write1ByteTxRx(port, 7, 4, 34)[:2] == (COMM_SUCCESS, 0)
    assert ph1.ping(port, 7)[1] == COMM_RX_TIMEOUT
    port.setBaudRate(57600)
    assert ph1.ping(port, 7)[:2] == (AX12A, COMM_SUCCESS)


def test_the_ax_refuses_read_only_items_and_keeps_quiet_at_status_level_0(make_bus, sdk1):
    bus = make_bus({7: AX12A}, **UNBOXED)
    port, ph1, _ = sdk1(bus.path)
    assert ph1.write2ByteTxRx(port, 7, 0, 99) == (COMM_SUCCESS, 0x08)   # Model Number: Range Error
    assert ph1.read2ByteTxRx(port, 7, 0)[0] == AX12A
    ph1.write1ByteTxRx(port, 7, 16, 0)                                   # Status Return Level 0
    assert ph1.read1ByteTxRx(port, 7, 3)[1] == COMM_RX_TIMEOUT
    assert ph1.ping(port, 7)[1] == COMM_RX_TIMEOUT  # the ping answers, its model read does not
    assert bus.servos_at(7)[0].read("status_return_level") == 0


def test_two_axes_at_one_id_collide(make_bus, make_raw):
    bus = make_bus([(7, AX12A), (7, AX12A)], **UNBOXED)
    raw = make_raw(bus.path)
    alone = b"\xff\xff\x07\x02\x00\xf6"   # one AX's ping reply (checksum ~(7+2+0))
    expected = bytearray(alone + b"\xff\xff")
    for i, byte in enumerate(alone):   # the second two byte-times later, wired-AND
        expected[2 + i] &= byte
    reply = raw.exchange(build_instruction1(7, 0x01), 8)
    assert reply == bytes(expected) and reply[:6] != alone


def test_the_state_file_keeps_its_id_and_baud_rate(tmp_path, make_bus, sdk1):
    state = str(tmp_path / "bus.json")
    bus = make_bus({7: AX12A, 1: XM430}, state_file=state, **UNBOXED)
    port, ph1, _ = sdk1(bus.path)
    ph1.write1ByteTxRx(port, 7, 3, 9)
    ph1.write1ByteTxRx(port, 9, 4, 34)
    bus.save_state()
    again = VirtualBus(state_file=state, wire_timing=False)
    (ax,) = again.servos_at(9)
    assert (ax.model.name, ax.read("baud_rate"), ax.baudrate) == ("AX-12A", 34, 57600)
    assert again.servo(1).model.number == XM430 and again.servos_at(7) == []


def test_protocol1_models_are_not_the_handlers():
    assert not any(m.name.startswith("AX") for m in known_models())
    with pytest.raises(KeyError):
        model_by_number(AX12A)


def test_the_command_takes_ax12a_by_name_and_on_stdin():
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "dynamixel_handler.sim", "--no-wire-timing", "--servo", "7:AX-12A"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        path = proc.stdout.readline().strip()
        proc.stdin.write("add 8 AX-12A\n")
        proc.stdin.flush()
        port = PatientPort(path)
        assert port.openPort() and port.setBaudRate(1_000_000)
        ph1 = PacketHandler(1.0)
        assert ph1.ping(port, 7)[:2] == (AX12A, COMM_SUCCESS)
        for _ in range(50):  # the add is read from stdin by another thread
            if ph1.ping(port, 8)[1] == COMM_SUCCESS:
                break
        assert ph1.ping(port, 8)[:2] == (AX12A, COMM_SUCCESS)
        port.closePort()
    finally:
        _, err = proc.communicate("quit\n", timeout=20)
    assert "ID 7: AX-12A (12) at 1000000 bps [Protocol 1.0]" in err


def test_an_x_servo_set_to_protocol_1_answers_1_0_until_set_back(make_bus, sdk1):
    """Protocol Type (address 13) 1: the XM430 answers Protocol 1.0 with its own control table and
    no longer 2.0; Protocol Type 2 written through 1.0 brings it back."""
    bus = make_bus({1: XM430}, baudrate=1_000_000, wire_timing=False)
    port, ph1, ph2 = sdk1(bus.path)
    assert ph1.ping(port, 1)[1] == COMM_RX_TIMEOUT
    assert ph2.write1ByteTxRx(port, 1, 13, 1) == (COMM_SUCCESS, 0)
    assert ph2.ping(port, 1)[1] == COMM_RX_TIMEOUT
    assert ph1.ping(port, 1) == (XM430, COMM_SUCCESS, 0)
    assert ph1.read1ByteTxRx(port, 1, 7)[:2] == (1, COMM_SUCCESS)        # ID at its X address
    assert ph1.write1ByteTxRx(port, 1, 64, 1) == (COMM_SUCCESS, 0)       # torque on
    assert ph1.write1ByteTxRx(port, 1, 13, 2) == (COMM_SUCCESS, 0x08)    # EEPROM with torque on: refused
    ph1.write1ByteTxRx(port, 1, 64, 0)
    assert ph1.write1ByteTxRx(port, 1, 13, 2) == (COMM_SUCCESS, 0)
    assert ph2.ping(port, 1)[:2] == (XM430, COMM_SUCCESS)


def test_model_names_on_the_command_line_prefer_the_protocol_2_firmware():
    from dynamixel_handler.sim.cli import parse_model
    # the names issue and manuals use: MX-28 is the MX-28(2.0) the handler drives
    assert [parse_model(t) for t in ("MX-28", "mx-28(2.0)", "MX-64", "MX-106", "30")] == [30, 30, 311, 321, 30]
    # the Protocol 1.0 firmware by its own spelling or number; AX names have no 2.0 twin
    assert [parse_model(t) for t in ("MX-28(1.0)", "29", "AX-12A", "12")] == [29, 29, 12, 12]


def test_the_model_list_names_the_parameter_that_drives_a_protocol1_model_and_ends_quietly_in_a_pipe():
    listed = subprocess.run([sys.executable, "-m", "dynamixel_handler.sim", "--list-models"], capture_output=True,
                            text=True, timeout=60)
    assert listed.returncode == 0, listed.stderr
    ax = next(line for line in listed.stdout.splitlines() if "AX-12A" in line)
    assert "init/used_servo_series.AX" in ax
    # a reader that closes the pipe before reading (as `| head -1` may, after its line): no traceback
    piped = subprocess.run(f"{sys.executable} -m dynamixel_handler.sim --list-models | true; exit ${{PIPESTATUS[0]}}",
                           shell=True, executable="/bin/bash", capture_output=True, text=True, timeout=60)
    assert piped.returncode == 0 and "Traceback" not in piped.stderr and "BrokenPipe" not in piped.stderr, piped.stderr
