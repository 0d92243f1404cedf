"""The baud rate unification: servos at mixed rates on a virtual bus that, like a real one, only
answers at each servo's own Baud Rate; the ROS-free function and the installed tool as a process."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.bus.ops import Ping, Write
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler.tools.baudrate import baud_register_values, search_rates, unify_baudrate, validate_tool_params

ROOT = Path(__file__).resolve().parent.parent
X, X540, XL330, P, PRO = 1020, 1120, 1200, 2020, 54024  # XM430-W350, XM540-W270, XL330-M288, PH54, H54 (old PRO)
ALL_RATES = search_rates(0, 10**8)
#: the host's adapter latency [ms]: an FTDI's default. The virtual bus answers from a thread of this
#: process; with a 1 ms latency (an 8.5 ms reply wait) a loaded host can hold that thread back past it
LATENCY_MS = 16.0


def at_rates(sim: VirtualBus, rates: dict[int, int]) -> None:
    """Put each servo at a baud rate (as if configured earlier), via its own register value."""
    for dxl_id, bps in rates.items():
        servo = sim.servo(dxl_id)
        servo.write("baud_rate", baud_register_values(servo.model)[bps])


def answering(path: str, bps: int, ids=range(0, 8)) -> dict[int, int]:
    """What a fresh host sees when it scans at ``bps``."""
    with DynamixelBus(path, bps, latency_timer_ms=LATENCY_MS, retry_num=0) as bus:
        return bus.scan(ids)


def unify(sim: VirtualBus, target: int, ids=range(0, 8), rates=ALL_RATES):
    with DynamixelBus(sim.path, 57600, latency_timer_ms=LATENCY_MS, retry_num=1) as bus:
        report = unify_baudrate(bus, target, ids, rates)
        assert bus.baudrate == target
    return report


# ---------------------------------------------------------------------- the virtual bus's baud check
def test_virtual_servo_answers_only_at_its_baud_rate_and_switches_after_the_reply():
    with VirtualBus({1: X, 2: P}, check_baudrate=True) as sim:
        at_rates(sim, {2: 10_500_000})
        assert answering(sim.path, 57600) == {1: X}
        assert answering(sim.path, 10_500_000) == {2: P}
        assert answering(sim.path, 4_500_000) == {}
        with DynamixelBus(sim.path, 57600, latency_timer_ms=LATENCY_MS, retry_num=0) as bus:
            # the status reply of the Baud Rate write still comes at the old rate
            assert bus.execute(Write(1, model_by_number(X).item("baud_rate").address, bytes([3]), protocol=2)).value
            assert bus.execute(Ping(1, protocol=2)).value is None
        assert answering(sim.path, 1_000_000) == {1: X}


def test_without_the_check_servos_answer_at_any_host_rate():
    with VirtualBus({1: X}, check_baudrate=False) as sim:
        at_rates(sim, {1: 115200})
        assert answering(sim.path, 3_000_000) == {1: X}


def test_register_values_follow_the_series():
    assert baud_register_values(model_by_number(X))[4_500_000] == 7
    assert 4_500_000 not in baud_register_values(model_by_number(XL330))
    assert baud_register_values(model_by_number(P))[6_000_000] == 8
    assert baud_register_values(model_by_number(P))[10_500_000] == 9
    assert baud_register_values(model_by_number(PRO))[10_500_000] == 8
    assert 6_000_000 not in baud_register_values(model_by_number(PRO))


# ---------------------------------------------------------------------- unify_baudrate()
def test_servos_at_mixed_rates_all_end_at_the_target_and_are_verified():
    servos = {1: X, 2: X540, 3: P, 4: PRO}
    with VirtualBus(servos, check_baudrate=True) as sim:
        at_rates(sim, {1: 57600, 2: 115200, 3: 1_000_000, 4: 10_500_000})
        sim.servo(1).write("torque_enable", 1)  # EEPROM: the tool has to turn torque off first
        report = unify(sim, 1_000_000)
        assert report.ok, report.summary()
        assert sorted(report.moved) == [1, 2, 4] and report.already == [3]
        assert {s.found_at for s in report.servos.values()} == {57600, 115200, 1_000_000, 10_500_000}
        assert report.verified == servos
        assert {i: s.baudrate for i, s in sim.servos.items()} == dict.fromkeys(servos, 1_000_000)
        assert answering(sim.path, 1_000_000) == servos
        assert answering(sim.path, 57600) == {}


def test_target_rate_the_model_cannot_use_is_a_failure_and_the_servo_stays():
    with VirtualBus({1: X, 5: XL330}, check_baudrate=True) as sim:
        report = unify(sim, 4_500_000)
        assert not report.ok
        assert report.moved == [1]
        assert "XL330-M288 cannot use 4500000 bps" in report.failed[5]
        assert sim.servo(5).baudrate == 57600 and sim.servo(1).baudrate == 4_500_000
        assert any("FAILED" in line for line in report.summary())


class _SpoilAfter:
    """A log that cuts the next reply short once a line containing ``text`` is logged."""

    def __init__(self, sim: VirtualBus, text: str) -> None:
        self.sim, self.text, self.lines = sim, text, []

    def _line(self, line: str) -> None:
        self.lines.append(line)
        if self.text in line:
            self.sim.truncate_next(1)

    info = warning = error = _line


def test_a_servo_that_misses_the_verification_ping_is_asked_again_before_it_is_called_failed():
    """Noise on the first ping at the target (its reply cut short) is no reason to report a moved
    servo lost: the tool pings it again."""
    with VirtualBus({1: X}, check_baudrate=True) as sim:
        log = _SpoilAfter(sim, "Baud Rate 57600 -> 1000000")  # the move's last transaction
        with DynamixelBus(sim.path, 57600, latency_timer_ms=LATENCY_MS, retry_num=1) as bus:
            report = unify_baudrate(bus, 1_000_000, range(0, 3), [57600], log=log)
        assert sim.stats["truncated"] == 1  # the verification scan's ping went unanswered
        assert report.ok, report.summary()
        assert report.moved == [1] and report.verified == {1: X}
        assert "verification at 1000000 bps: 1 of 1 answer" in log.lines


def test_two_servos_sharing_an_id_at_different_rates_are_not_merged():
    with VirtualBus({1: X, 2: X}, check_baudrate=True) as sim:
        at_rates(sim, {2: 115200})
        sim.servo(2).write("id", 1)  # ID 1 at 57600 and ID 1 at 115200
        report = unify(sim, 57600)
        assert not report.ok
        assert "two servos share this ID" in report.failed[1]
        assert answering(sim.path, 57600) == {1: X} and answering(sim.path, 115200) == {1: X}


def test_no_servo_anywhere_is_a_failure_with_the_searched_rates():
    with VirtualBus({9: X}, check_baudrate=True) as sim:
        report = unify(sim, 57600, ids=range(0, 3), rates=[57600, 115200])
        assert not report.ok
        assert "no servo answered" in report.error and "115200" in report.error


def test_tool_parameters_are_checked_with_one_clear_sentence():
    assert validate_tool_params({}).target_baudrate == 1_000_000
    assert validate_tool_params({"latency_timer": 4.0}).latency_timer == 4
    bad = {"target_baudrate": 12345, "max_id": 300, "latency_timer": 0, "min_id": "one",
           "min_search_baudrate": 5_000_000}
    for name, value in bad.items():
        with pytest.raises(ValueError, match=name) as err:
            validate_tool_params({name: value, **({"max_search_baudrate": 5_500_000} if "search" in name else {})})
        assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="'max_id' = 2 is below 'min_id' = 5"):
        validate_tool_params({"min_id": 5, "max_id": 2})


# ---------------------------------------------------------------------- the installed tool, as a process
TOOL = shutil.which("dynamixel_unify_baudrate")
needs_tool = pytest.mark.skipif(TOOL is None, reason="dynamixel_unify_baudrate not installed (source env.sh)")


def run_tool(*params: str, timeout: float = 30.0) -> subprocess.CompletedProcess:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", RCUTILS_LOGGING_BUFFERED_STREAM="0")
    cmd = [TOOL, "--ros-args", "--params-file", str(ROOT / "config" / "config_unify_baudrate.yaml")]
    for p in params:
        cmd += ["-p", p]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    out.text = out.stdout + out.stderr
    return out


@needs_tool
def test_tool_process_moves_mixed_rates_to_the_target():
    servos = {1: X, 2: X540, 3: P}
    with VirtualBus(servos, check_baudrate=True) as sim:
        at_rates(sim, {1: 57600, 2: 115200, 3: 1_000_000})
        out = run_tool(f"device_name:={sim.path}", "target_baudrate:=2000000", "latency_timer:=1",
                       "min_id:=1", "max_id:=5", "max_search_baudrate:=4500000")
        assert out.returncode == 0, out.text
        assert "3 servo(s) found, 0 already at the target, 3 moved, 0 failed" in out.text
        assert "Traceback" not in out.text
        assert {i: s.baudrate for i, s in sim.servos.items()} == dict.fromkeys(servos, 2_000_000)


@needs_tool
def test_tool_process_bad_parameter_gives_one_line_and_nonzero_exit():
    out = run_tool("device_name:=/dev/null", "target_baudrate:=12345")
    assert out.returncode == 2
    lines = [line for line in out.text.splitlines() if line.strip()]
    assert len(lines) == 1, out.text
    assert "ERROR" in lines[0] and "'target_baudrate' = 12345 is not a Dynamixel baud rate" in lines[0]


@needs_tool
def test_tool_process_missing_device_says_so():
    out = run_tool("device_name:=/dev/ttyDXL-missing-device")
    assert out.returncode == 1
    assert "/dev/ttyDXL-missing-device does not exist" in out.text
    assert "Traceback" not in out.text


def test_sim_command_line_check_baudrate_flag():
    proc = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--check-baudrate", "--quiet",
                             "--servo", "1:XM430-W350"], stdout=subprocess.PIPE, stdin=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        path = proc.stdout.readline().strip()
        assert answering(path, 57600) == {1: X}
        assert answering(path, 1_000_000) == {}
    finally:
        proc.terminate()
        proc.wait(10)


@needs_tool
def test_tool_against_the_default_virtual_bus_finds_each_servo_once(tmp_path):
    """The virtual bus as it starts with no flags: its servos answer at their own 57600 bps only,
    so the tool sees each of them once and moves them all, with no false ID clash."""
    state = tmp_path / "bus.json"
    proc = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--state", str(state)],
                            stdout=subprocess.PIPE, stdin=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        path = proc.stdout.readline().strip()
        out = run_tool(f"device_name:={path}", "latency_timer:=1", "min_id:=0", "max_id:=6", timeout=60)
        assert out.returncode == 0, out.text
        assert "4 servo(s) found, 0 already at the target, 4 moved, 0 failed" in out.text, out.text
        assert "share this ID" not in out.text and "Traceback" not in out.text
        assert answering(path, 1_000_000) == {1: X, 2: X540, 3: P, 4: PRO}
    finally:
        proc.terminate()
        proc.wait(10)
    # the new baud rates were kept in the bus's state file, as a servo keeps its EEPROM
    proc = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--state", str(state)],
                            stdout=subprocess.PIPE, stdin=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        path = proc.stdout.readline().strip()
        assert answering(path, 1_000_000) == {1: X, 2: X540, 3: P, 4: PRO}
        assert answering(path, 57600) == {}
    finally:
        proc.terminate()
        proc.wait(10)
