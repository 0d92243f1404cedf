"""dynamixel_handler_setup on a standing robot, as a process against the virtual bus (a process
with ``--state``), every result read back with dynamixel_sdk: torque is the owner's to give
(``--torque-off``), Ctrl-C / SIGTERM after each bus instruction of a torque-off write and of a
set-baud leave each servo in a state the output names (exit 130), a scan stopped keeps what it found,
units are required, ranges / limit pairs / dangerous values are checked before anything is sent,
no one-way door to Protocol 1.0, collisions said as they are, bad input one line (exit 2)."""
from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Iterator

import pytest
import test_setup_tool
from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler
from test_setup_tool import ENV, ROOT, TOOL, XM430, one_error_line

from support.sdk import PatientPort

sim_of = test_setup_tool.sim_of  # the fixture: the virtual bus as a process


def tool(sim, *args: str, stdin: str = "") -> subprocess.CompletedProcess:
    """The tool as a process, with reply timeouts for a loaded host (a 100 ms latency timer)."""
    return test_setup_tool.tool(sim, *args, "--latency", "100", stdin=stdin)


def _settle(port: PatientPort) -> None:
    """Drop the input after a short settle: on a loaded host a reply to an earlier request (the
    tool's, or an SDK request that timed out) may still arrive, and must not be taken for the next
    request's."""
    time.sleep(0.05)
    port.ser.reset_input_buffer()


@contextlib.contextmanager
def _port(path: str, bps: int, patient: bool = True) -> Iterator[PortHandler]:
    """dynamixel_sdk's port at ``bps``, settled (``_settle``) when opened and after each request
    that failed; requests that succeed follow each other on it without a wait. ``patient`` False:
    the SDK's own reply wait (for a first look, where a late reply only means asking again)."""
    port = PatientPort(path) if patient else PortHandler(path)
    assert port.openPort() and port.setBaudRate(bps)
    try:
        _settle(port)
        yield port
    finally:
        port.closePort()


def _tries(port: PatientPort, request):
    """``request(packets)`` up to three times until dynamixel_sdk reports success, the port settled
    after each failure; its result (None when it never succeeded)."""
    for _ in range(3):
        ok, got = request(PacketHandler(2.0))
        if ok:
            return got
        _settle(port)
    return None


def port_read(port: PatientPort, dxl_id: int, address: int, size: int) -> int | None:
    def request(packets):
        data, comm, _err = packets.readTxRx(port, dxl_id, address, size)
        return comm == COMM_SUCCESS, int.from_bytes(bytes(data), "little", signed=size == 4)
    return _tries(port, request)


def port_write(port: PatientPort, dxl_id: int, address: int, value: int, size: int) -> None:
    def request(packets):
        if size == 1:
            comm, err = packets.write1ByteTxRx(port, dxl_id, address, value)
        else:
            comm, err = packets.write4ByteTxRx(port, dxl_id, address, value & 0xFFFFFFFF)
        return comm == COMM_SUCCESS and err == 0, True
    assert _tries(port, request), (dxl_id, address, value)


def sdk_read(path: str, bps: int, dxl_id: int, address: int, size: int) -> int | None:
    with _port(path, bps) as port:
        return port_read(port, dxl_id, address, size)


def sdk_ping(path: str, bps: int, dxl_id: int) -> int | None:
    with _port(path, bps) as port:
        def request(packets):
            model, comm, _err = packets.ping(port, dxl_id)
            return comm == COMM_SUCCESS, model
        return _tries(port, request)


def sdk_write1(path: str, bps: int, dxl_id: int, address: int, value: int) -> None:
    with _port(path, bps) as port:
        port_write(port, dxl_id, address, value, 1)


def sdk_write4(path: str, bps: int, dxl_id: int, address: int, value: int) -> None:
    with _port(path, bps) as port:
        port_write(port, dxl_id, address, value, 4)


TORQUE, BAUD, ID_ADDR, DRIVE, SECONDARY, PROTOCOL, TEMP_LIMIT, SHUTDOWN = 64, 8, 7, 10, 12, 13, 31, 63
MAX_POS, MIN_POS, CURRENT_LIMIT, GOAL_VEL, GOAL_POS, PRESENT_POS = 48, 52, 38, 104, 116, 132
RETURN_DELAY, LED = 9, 65
PAUSE = "DXL_SETUP_TEST_PAUSE_AFTER"


def hold(sim, dxl_id: int = 1, bps: int = 57600) -> None:
    """Torque on where the servo is, as an arm holding its weight."""
    with _port(sim.path, bps) as port:
        port_write(port, dxl_id, GOAL_POS, port_read(port, dxl_id, PRESENT_POS, 4), 4)
        port_write(port, dxl_id, TORQUE, 1, 1)


# ---------------------------------------------------------------------- item 1: torque
def test_an_eeprom_write_on_a_servo_holding_its_load_is_refused_unless_torque_off_is_given(sim_of):
    sim = sim_of("1:XM430-W350")
    hold(sim)
    for args in (("set", "1", "max_position_limit", "90deg"), ("set-mode", "1", "velocity"), ("set-id", "1", "4"),
                 ("set-baud", "1", "1M")):
        out = tool(sim, *args, "--yes", "--baud", "57600")
        assert out.returncode == 2, (args, out.text)
        line = one_error_line(out)
        assert "torque is on" in line and "--torque-off" in line and "nothing written" in line, line
    assert sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1  # never dropped
    assert (sdk_read(sim.path, 57600, 1, MAX_POS, 4), sdk_read(sim.path, 57600, 1, 11, 1)) == (4095, 3)
    assert sdk_ping(sim.path, 57600, 4) is None and sdk_ping(sim.path, 1_000_000, 1) is None

    out = tool(sim, "set", "1", "max_position_limit", "90deg", "--torque-off", "--baud", "57600", stdin="n\n")  # the prompt says it
    assert out.returncode == 1 and "Its torque is on: it goes off for the write" in out.stdout, out.text
    assert sdk_read(sim.path, 57600, 1, MAX_POS, 4) == 4095

    out = tool(sim, "set", "1", "max_position_limit", "90deg", "--torque-off", "--yes", "--baud", "57600")
    assert out.returncode == 0, out.text
    assert "torque was turned off for the write and back on" in out.stdout, out.text
    assert sdk_read(sim.path, 57600, 1, MAX_POS, 4) == 3072 and sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1
    present = sdk_read(sim.path, 57600, 1, PRESENT_POS, 4)
    assert abs(sdk_read(sim.path, 57600, 1, GOAL_POS, 4) - present) < 20  # goal := where it is

    sdk_write1(sim.path, 57600, 1, TORQUE, 0)  # torque off: nothing to ask
    out = tool(sim, "set", "1", "max_position_limit", "80deg", "--yes", "--baud", "57600")
    assert out.returncode == 0 and "torque was turned off" not in out.stdout, out.text
    assert sdk_read(sim.path, 57600, 1, TORQUE, 1) == 0


def test_reboot_and_factory_reset_of_a_servo_holding_its_load_need_torque_off(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM430-W350")
    sdk_write1(sim.path, 57600, 1, RETURN_DELAY, 20)  # set up before: a factory reset would undo it
    hold(sim)
    for dxl_id in (1, 2):
        sdk_write1(sim.path, 57600, dxl_id, LED, 1)  # RAM: back to 0 after a reboot

    out = tool(sim, "reboot", "all", "--baud", "57600", "--yes")
    assert out.returncode == 2 and "torque is on and a reboot turns it off" in one_error_line(out), out.text
    out = tool(sim, "reboot", "all", "--baud", "57600", "--torque-off", stdin="n\n")  # asked first
    assert out.returncode == 1 and "ID 1 hold their load (torque on)" in out.stdout, out.text
    assert [sdk_read(sim.path, 57600, i, LED, 1) for i in (1, 2)] == [1, 1]  # nothing rebooted
    assert sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1

    out = tool(sim, "reboot", "all", "--baud", "57600", "--torque-off", "--yes")
    assert out.returncode == 0 and "ID 1 (XM430-W350) rebooted and answers again, torque back on" in out.stdout, out.text
    assert [sdk_read(sim.path, 57600, i, LED, 1) for i in (1, 2)] == [0, 0]
    assert [sdk_read(sim.path, 57600, i, TORQUE, 1) for i in (1, 2)] == [1, 0]  # each as before
    assert abs(sdk_read(sim.path, 57600, 1, GOAL_POS, 4) - sdk_read(sim.path, 57600, 1, PRESENT_POS, 4)) < 20

    out = tool(sim, "factory-reset", "1", "--keep", "id,baud", "--yes", "--baud", "57600")
    assert out.returncode == 2 and "torque is on and a factory reset turns it off" in one_error_line(out), out.text
    assert sdk_read(sim.path, 57600, 1, RETURN_DELAY, 1) == 20 and sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1
    out = tool(sim, "factory-reset", "1", "--keep", "id,baud", "--yes", "--torque-off", "--baud", "57600")
    assert out.returncode == 0 and "torque off (the factory state)" in out.stdout, out.text
    assert sdk_read(sim.path, 57600, 1, RETURN_DELAY, 1) == 250 and sdk_read(sim.path, 57600, 1, TORQUE, 1) == 0


# ---------------------------------------------------------------------- item 2: signals
class Paused:
    """The tool as a process that pauses before the bus instruction after the ``after``-th (the
    test hook); stdout and stderr read in a thread."""

    def __init__(self, sim, after: int, *args: str) -> None:
        cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
        self.proc = subprocess.Popen([*cmd, "--device", sim.path, "--latency", "100", *args], stdin=subprocess.DEVNULL,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
                                     env=dict(ENV, **{PAUSE: str(after)}))
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def paused(self, timeout: float = 60.0) -> bool:
        """True once the tool paused; False when it ended without reaching that instruction."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if any(f"[{PAUSE}] paused" in line for line in self.lines):
                return True
            if self.proc.poll() is not None:
                self._reader.join(5)
                return any(f"[{PAUSE}] paused" in line for line in self.lines)
            time.sleep(0.02)
        self.proc.kill()
        raise AssertionError("the tool neither paused nor ended:\n" + "\n".join(self.lines))

    def finish(self) -> tuple[int, str]:
        code = self.proc.wait(60)
        self._reader.join(5)
        return code, "\n".join(self.lines)


def _where(sim) -> int:
    """The rate ID 1 answers at (exactly one of 57600 and 1 Mbps): both rates asked once a round,
    up to three rounds until it answers at one (a loaded host can make a reply late, never make an
    absent servo answer, so a rate is not asked again once the other answered). The first round
    waits as the SDK does, the later ones as a loaded host needs."""
    def answers(bps: int, patient: bool) -> bool:
        with _port(sim.path, bps, patient) as port:
            model, comm, _err = PacketHandler(2.0).ping(port, 1)
        return comm == COMM_SUCCESS and model == XM430

    at: list[int] = []
    for round_ in range(3):
        at = [bps for bps in (57600, 1_000_000) if answers(bps, patient=round_ > 0)]
        if at:
            break
    assert len(at) == 1, at
    return at[0]


def _back_to_start(sim, bps: int) -> None:
    """ID 1 at 57600 bps, max position limit 4095, holding its position (torque on); ``bps``: the
    rate it answers at now (the last ``_where``)."""
    with _port(sim.path, bps) as port:
        port_write(port, 1, TORQUE, 0, 1)
        if bps != 57600:
            port_write(port, 1, BAUD, 1, 1)
    with _port(sim.path, 57600) as port:
        port_write(port, 1, MAX_POS, 4095, 4)
        port_write(port, 1, GOAL_POS, port_read(port, 1, PRESENT_POS, 4), 4)  # hold(): torque on where it is
        port_write(port, 1, TORQUE, 1, 1)


@pytest.mark.parametrize("verb", ["set", "set-baud"])
def test_a_signal_after_each_bus_instruction_leaves_the_servo_in_a_named_state(sim_of, verb):
    sim = sim_of("1:XM430-W350")
    args = {"set": ("set", "1", "max_position_limit", "90deg"), "set-baud": ("set-baud", "1", "1M")}[verb]
    stops, bps = 0, 57600
    for after in range(0, 60):
        signum = (signal.SIGINT, signal.SIGTERM)[after % 2]  # both signals, each at every other point
        _back_to_start(sim, bps)
        run = Paused(sim, after, *args, "--torque-off", "--yes", "--baud", "57600")
        if not run.paused():  # the whole run has fewer instructions: every point was tried
            code, text = run.finish()
            assert code == 0, text
            break
        run.proc.send_signal(signum)
        code, text = run.finish()
        stops += 1
        name = signal.Signals(signum).name
        assert code == 130, (after, text)
        assert "Traceback" not in text and f"interrupted ({name})" in text, (after, text)
        bps = _where(sim)
        with _port(sim.path, bps) as port:
            assert port_read(port, 1, TORQUE, 1) == 1, (after, text)  # torque as before: on
            limit = port_read(port, 1, MAX_POS, 4)
        if verb == "set":
            assert bps == 57600, (after, text)
            if limit != 4095:  # written: the output says so
                assert limit == 3072 and "max_position_limit" in text and "written and read back" in text, (after, text)
            else:
                assert "written and read back" not in text, (after, text)
        else:
            assert limit == 4095
            if bps != 57600:  # moved: the output names the rate it is at now
                assert "at 1000000 bps, torque on" in text and "baud_rate" in text, (after, text)
            else:
                assert "written and read back" not in text, (after, text)
    else:
        raise AssertionError("the run never ended without a pause")
    assert stops >= 8, stops  # every instruction of the step was a stopping point


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGHUP], ids=["SIGINT", "SIGHUP"])
def test_a_signal_during_a_reboot_of_a_servo_holding_its_load_leaves_its_torque_on(sim_of, signum):
    sim = sim_of("1:XM430-W350")
    stops = 0
    for after in range(0, 80):
        _back_to_start(sim, 57600)  # a reboot keeps the rate: each stop below reads it at 57600 bps
        sdk_write1(sim.path, 57600, 1, LED, 1)  # RAM: 0 once rebooted
        run = Paused(sim, after, "reboot", "1", "--torque-off", "--yes", "--baud", "57600")
        if not run.paused():
            code, text = run.finish()
            assert code == 0, text
            break
        run.proc.send_signal(signum)
        code, text = run.finish()
        stops += 1
        assert code == 130 and f"interrupted ({signal.Signals(signum).name})" in text, (after, text)
        assert sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1, (after, text)  # torque as before: on
        rebooted = sdk_read(sim.path, 57600, 1, LED, 1) == 0
        assert rebooted == ("rebooted" in text), (after, text)  # said exactly when done
    else:
        raise AssertionError("the run never ended without a pause")
    assert stops >= 5, stops


def test_json_of_an_interrupted_set_baud_names_the_servo_where_it_is(sim_of):
    sim = sim_of("1:XM430-W350")
    hold(sim)
    for after in range(4, 30):  # the first stop inside the step (the Baud Rate written) ends it there
        run = Paused(sim, after, "set-baud", "1", "1M", "--torque-off", "--yes", "--baud", "57600", "--json")
        assert run.paused(), "\n".join(run.lines)
        run.proc.send_signal(signal.SIGTERM)
        code, text = run.finish()
        assert code == 130, text
        doc = json.loads(text[text.index("{"):])
        if "touched" in doc:
            break
    else:
        raise AssertionError("no stop inside the step")
    assert doc["touched"] == [{"id": 1, "model": "XM430-W350", "baudrate": 1_000_000, "torque": "on (as before)",
                               "done": [doc["touched"][0]["done"][0]]}], doc
    assert "baud_rate" in doc["touched"][0]["done"][0] and "written and read back" in doc["touched"][0]["done"][0]
    assert sdk_ping(sim.path, 1_000_000, 1) == XM430 and sdk_read(sim.path, 1_000_000, 1, TORQUE, 1) == 1


def test_an_interrupted_scan_emits_what_it_had_found(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM540-W270")
    run = Paused(sim, 25, "scan", "--ids", "0-3", "--json")  # after the first rate (57600), before the end
    assert run.paused()
    run.proc.send_signal(signal.SIGINT)
    code, text = run.finish()
    assert code == 130, text
    doc = json.loads(text[text.index("{"):])
    assert doc["interrupted"] and not doc["ok"], doc
    assert [(s["id"], s["baudrate"]) for s in doc["servos"]] == [(1, 57600), (2, 57600)], text


# ---------------------------------------------------------------------- item 7: units
def test_a_bare_number_for_an_item_with_a_unit_is_refused_with_both_readings(sim_of):
    sim = sim_of("1:XM430-W350")
    out = tool(sim, "set", "1", "max_position_limit", "90", "--yes", "--baud", "57600")
    assert out.returncode == 2, out.text
    line = one_error_line(out)
    assert "90 = 90 deg? write 90deg, or --raw for register value 90" in line and "-172" in line, line
    assert sdk_read(sim.path, 57600, 1, MAX_POS, 4) == 4095
    out = tool(sim, "set", "1", "max_position_limit", "3000", "--raw", "--yes", "--baud", "57600")
    assert out.returncode == 0, out.text
    assert sdk_read(sim.path, 57600, 1, MAX_POS, 4) == 3000


def test_ranges_and_limit_pairs_are_checked_before_anything_is_sent(sim_of):
    sim = sim_of("1:XM430-W350")
    sdk_write4(sim.path, 57600, 1, MAX_POS, 3072)  # +90 deg
    cases = {("min_position_limit", "100deg"): "would not be below max_position_limit",
             ("max_position_limit", "-180deg"): "would not be below max_position_limit",
             ("temperature_limit", "150degC"): "outside what the e-Manual gives XM430-W350",
             ("current_limit", "65535", "--raw"): "outside what the e-Manual gives XM430-W350",
             ("goal_position", "100deg"): "outside the position limits", ("goal_velocity", "1000rpm"): "beyond velocity_limit"}
    goals = [sdk_read(sim.path, 57600, 1, a, 4) for a in (GOAL_POS, GOAL_VEL)]
    for args, text in cases.items():
        out = tool(sim, "set", "1", *args, "--yes", "--baud", "57600")
        assert out.returncode == 2 and text in one_error_line(out), (args, out.text)
    assert [sdk_read(sim.path, 57600, 1, a, n) for a, n in ((MIN_POS, 4), (MAX_POS, 4), (TEMP_LIMIT, 1),
                                                              (CURRENT_LIMIT, 2))] == [0, 3072, 80, 1193]
    assert [sdk_read(sim.path, 57600, 1, a, 4) for a in (GOAL_POS, GOAL_VEL)] == goals


# ---------------------------------------------------------------------- items 3, 6: dangerous values
def test_protection_lowering_values_need_force_and_protocol_type_1_warns_what_it_means(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM430-W350")
    for item, value in (("shutdown", "0"), ("drive_mode", "1"), ("secondary_id", "2"), ("temperature_limit", "90degC")):
        out = tool(sim, "set", "1", item, value, "--yes", "--baud", "57600")
        assert out.returncode == 2, (item, out.text)
        line = one_error_line(out)
        assert "--force writes it anyway" in line and "nothing written" in line, line
    assert [sdk_read(sim.path, 57600, 1, a, 1) for a in (SHUTDOWN, DRIVE, SECONDARY, TEMP_LIMIT)] == [52, 0, 255, 80]
    out = tool(sim, "set", "1", "shutdown", "0", "--yes", "--force", "--baud", "57600")
    assert out.returncode == 0 and sdk_read(sim.path, 57600, 1, SHUTDOWN, 1) == 0, out.text

    out = tool(sim, "set", "1", "protocol_type", "1", "--yes", "--force", "--baud", "57600")
    assert out.returncode == 0 and "it answers Protocol 1.0 only" in out.stderr, out.text  # allowed, with what it means
    assert "`set 1 protocol_type 2` brings it back" in out.stderr, out.text
    out = tool(sim, "set", "1", "protocol_type", "2", "--yes", "--baud", "57600")   # through Protocol 1.0, back to 2.0
    assert out.returncode == 0 and sdk_read(sim.path, 57600, 1, PROTOCOL, 1) == 2, out.text


def test_a_protocol_1_servo_is_listed_with_what_the_tool_can_do_with_it(sim_of):
    sim = sim_of("1:XM430-W350", "8:MX-28(1.0)")
    sdk_write1(sim.path, 57600, 1, PROTOCOL, 1)
    out = tool(sim, "scan", "--ids", "0-9", "--baud", "57600", "--json")
    assert out.returncode == 0, out.text
    notes = {s["id"]: s["note"] for s in json.loads(out.stdout)["servos"]}
    assert "`set 1 protocol_type 2`" in notes[1] and "every verb of this tool reaches it" in notes[1], notes
    assert "Firmware Recovery, MX-28(2.0)" in notes[8], notes
    out = tool(sim, "get", "1", "id", "--baud", "57600")  # every other verb reaches it in Protocol 1.0
    assert out.returncode == 0 and "ID 1 (XM430-W350) id = 1" in out.stdout, out.text


# ---------------------------------------------------------------------- item 10: collisions
def test_three_servos_at_one_id_are_two_or_more(sim_of):
    sim = sim_of("1:XM430-W350", "1:XM430-W350", "1:XM430-W350")
    out = tool(sim, "scan", "--ids", "0-2", "--baud", "57600", "--protocol", "2", "--json")
    assert out.returncode == 0, out.text
    (found,) = json.loads(out.stdout)["servos"]
    assert found["collision"] and "two or more servos answer at this ID" in found["note"] and "assign-ids" in found["note"]


def test_one_id_at_two_rates_is_refused_naming_both(sim_of):
    def tool(sim, *args: str):  # a search of many rates: a 30 ms latency timer, 2 retries (as the reach tests)
        return test_setup_tool.tool(sim, *args, "--latency", "30", "--retries", "2")

    sim = sim_of("1:XM430-W350", "2:XM430-W350")
    sdk_write1(sim.path, 57600, 2, BAUD, 3)
    sdk_write1(sim.path, 1_000_000, 2, ID_ADDR, 1)  # ID 1 at 57600 and at 1 Mbps
    out = tool(sim, "set-id", "1", "3", "--yes")
    assert out.returncode == 1, out.text
    line = one_error_line(out)
    assert "57600" in line and "1000000" in line, line
    assert sdk_ping(sim.path, 57600, 1) == XM430 and sdk_ping(sim.path, 1_000_000, 1) == XM430
    assert sdk_ping(sim.path, 57600, 3) is None and sdk_ping(sim.path, 1_000_000, 3) is None
    # every rate was looked at above; the rates of a --baud list are looked at alike (and quicker)
    lst = ("--baud", "57600,115200,1M")
    sdk_write1(sim.path, 57600, 1, RETURN_DELAY, 20)
    out = tool(sim, "factory-reset", "1", "--keep", "id", "--yes", *lst)
    assert out.returncode == 1 and "57600 and at 1000000" in one_error_line(out), out.text
    assert sdk_read(sim.path, 57600, 1, RETURN_DELAY, 1) == 20 and sdk_ping(sim.path, 1_000_000, 1) == XM430
    sdk_write1(sim.path, 57600, 1, LED, 1)
    out = tool(sim, "reboot", "1", "--yes", *lst)
    assert out.returncode == 1 and "57600 and at 1000000" in one_error_line(out), out.text
    assert sdk_read(sim.path, 57600, 1, LED, 1) == 1  # not rebooted
    # several IDs in one sync write / read: the same refusal, nothing written
    out = tool(sim, "set", "1,5", "led", "0", "--yes", *lst)
    assert out.returncode == 1 and "57600 and at 1000000" in out.text, out.text
    assert sdk_read(sim.path, 57600, 1, LED, 1) == 1
    out = tool(sim, "get", "1,5", "led", *lst)
    assert out.returncode == 1 and "57600 and at 1000000" in out.text, out.text
    for verb in (("get", "1", "led"), ("info", "1")):  # reading one of them would mislead as much
        out = tool(sim, *verb, *lst)
        assert out.returncode == 1 and "57600 and at 1000000" in one_error_line(out), out.text


# ---------------------------------------------------------------------- item 6: bad input, one line
def test_bad_numbers_and_long_input_are_one_line_with_exit_code_2(sim_of):
    sim = sim_of("1:XM430-W350")
    long_name = "x" * 100_000
    cases = [("--baud", "inf", "get", "1", "id"), ("--baud", "1e400", "get", "1", "id"), ("set-baud", "1", "inf"),
             ("--latency", "inf", "get", "1", "id"), ("--latency", "1e9", "get", "1", "id"),
             ("--retries", "99", "get", "1", "id"), ("set", "1", "goal_position", "1e400deg"),
             ("set", "1", "goal_position", "nan"), ("set", "1", "goal_position", "1e300deg"),
             ("set", "1", "torque_enable", "2"), ("reboot", "254"), ("reboot", "-1"), ("monitor", "--rate", "inf"),
             ("set", "1", long_name, "3"), ("get", "1", long_name), (long_name,)]
    for args in cases:
        out = tool(sim, *args, "--yes", *(() if "--baud" in args else ("--baud", "57600")))
        assert out.returncode == 2, (args[:4], out.text[:500])
        line = one_error_line(out)
        assert "unexpected" not in line and "defect" not in line and len(line) < 400, (args[:4], line[:500])
    out = tool(sim, "scan", "--ids", "1", "--baud", "57600", "--protocol", "2", "--svg", "/nonexistent/dir/scan.svg")
    assert out.returncode == 1 and "cannot write /nonexistent/dir/scan.svg" in one_error_line(out), out.text
    assert os.path.exists(sim.path)
    out = tool(sim, "--help")
    assert out.returncode == 0 and "130 interrupted" in " ".join(out.stdout.split()), out.text
