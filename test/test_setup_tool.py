"""dynamixel_handler_setup as a process against the virtual bus run as a process with ``--state``
(IDs and baud rates persist as on hardware), each result checked by reading the registers with
dynamixel_sdk directly: scan, assign-ids, set-id / set-baud / set of a limit in degrees, backup ->
factory reset -> restore, --json, bad arguments, the port lock against a running handler."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Iterator

import pytest
from dynamixel_sdk import COMM_SUCCESS, PacketHandler

from support.ros import PATIENT_SCAN, NodeProcess, node_command
from support.sdk import PatientPort

ROOT = Path(__file__).resolve().parent.parent
TOOL = shutil.which("dynamixel_handler_setup")
XM430, XM540, XL330, PH54, H54, AX12 = 1020, 1120, 1200, 2020, 54024, 12
ENV = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")


class Lines:
    """A process whose stdout is read line by line in a thread."""

    def __init__(self, cmd: list[str], stdin: bool = True) -> None:
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     stdin=subprocess.PIPE if stdin else subprocess.DEVNULL, text=True, cwd=ROOT, env=ENV)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, text: str, after: int = 0, timeout: float = 30.0) -> int:
        """Index of the first line from ``after`` on that holds ``text``."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for k in range(after, len(self.lines)):
                if text in self.lines[k]:
                    return k
            if self.proc.poll() is not None and not self._reader.is_alive():
                break
            time.sleep(0.05)
        raise AssertionError(f"no {text!r} in:\n" + "\n".join(self.lines))

    def send(self, line: str) -> None:
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


class Sim(Lines):
    """The virtual bus as a process: unboxed servos (57600 bps, their own rate only, wire timed)."""

    def __init__(self, state: Path, *servos: str) -> None:
        args = [a for s in servos for a in ("--servo", s)]
        super().__init__([sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--state", str(state), *args])
        self.wait_for("/")
        self.path = self.lines[0].strip()


@pytest.fixture
def sim_of(tmp_path):
    started: list[Sim] = []

    def start(*servos: str) -> Sim:
        sim = Sim(tmp_path / "bus.json", *servos)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.stop()


def tool(sim: Sim, *args: str, stdin: str = "", timeout: float = 60.0) -> subprocess.CompletedProcess:
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    out = subprocess.run([*cmd, "--device", sim.path, "--latency", "10", *args], input=stdin, capture_output=True,
                         text=True, timeout=timeout, env=ENV, cwd=ROOT)
    out.text = out.stdout + out.stderr
    assert "Traceback" not in out.text, out.text
    return out


# ---------------------------------------------------------------------- dynamixel_sdk, directly
@contextlib.contextmanager
def sdk_port(path: str, bps: int) -> Iterator[PatientPort]:
    """dynamixel_sdk's own port on the bus at ``bps``, closed afterwards."""
    port = PatientPort(path)
    assert port.openPort() and port.setBaudRate(bps)
    # a reply the tool's process left on the line (answered after it gave up on it, on a loaded
    # machine) would be taken for this read's: dropped
    port.clearPort()
    try:
        yield port
    finally:
        port.closePort()


def sdk_read(path: str, bps: int, dxl_id: int, address: int, size: int) -> int | None:
    with sdk_port(path, bps) as port:
        data, comm, _err = PacketHandler(2.0).readTxRx(port, dxl_id, address, size)
    return int.from_bytes(bytes(data), "little", signed=size == 4) if comm == COMM_SUCCESS else None


def sdk_bytes(path: str, bps: int, dxl_id: int, address: int, size: int) -> bytes | None:
    with sdk_port(path, bps) as port:
        data, comm, _err = PacketHandler(2.0).readTxRx(port, dxl_id, address, size)
    return bytes(data) if comm == COMM_SUCCESS else None


def sdk_write1(path: str, bps: int, dxl_id: int, address: int, value: int) -> None:
    with sdk_port(path, bps) as port:
        comm, err = PacketHandler(2.0).write1ByteTxRx(port, dxl_id, address, value)
    assert comm == COMM_SUCCESS and err == 0


def sdk_write4(path: str, bps: int, dxl_id: int, address: int, value: int) -> None:
    with sdk_port(path, bps) as port:
        comm, err = PacketHandler(2.0).write4ByteTxRx(port, dxl_id, address, value & 0xFFFFFFFF)
    assert comm == COMM_SUCCESS and err == 0


def sdk_ping(path: str, bps: int, dxl_id: int) -> int | None:
    with sdk_port(path, bps) as port:
        model, comm, _err = PacketHandler(2.0).ping(port, dxl_id)
    return model if comm == COMM_SUCCESS else None


def one_error_line(out: subprocess.CompletedProcess) -> str:
    lines = [line for line in out.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), out.text
    return lines[0]


BAUD_RATE_ADDR, MAX_POSITION_ADDR = 8, 48  # X series (ROBOTIS e-Manual, XM430-W350 control table)


# ---------------------------------------------------------------------- scan
def test_scan_finds_five_servos_at_three_rates_two_that_collide_and_an_ax12(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM540-W270", "3:PH54-200-S500-R", "4:H54-200-S500-R", "5:XL330-M288",
                 "6:XM430-W350", "6:XM430-W350", "7:AX-12A", "8:MX-28(1.0)")
    # servos 3 and 5 at 1 Mbps, 4 at 115200 (Baud Rate register 3 / 2), written with the SDK
    for dxl_id, value in ((3, 3), (4, 2), (5, 3)):
        sdk_write1(sim.path, 57600, dxl_id, BAUD_RATE_ADDR, value)
    out = tool(sim, "scan", "--ids", "0-9", "--baud", "57600,115200,1000000", "--json")
    assert out.returncode == 0, out.text
    found = json.loads(out.stdout)["servos"]
    clean = {(f["id"], f["baudrate"], f["model_number"]) for f in found if f["protocol"] == 2 and not f["collision"]}
    assert clean == {(1, 57600, XM430), (2, 57600, XM540), (3, 1_000_000, PH54), (4, 115200, H54),
                     (5, 1_000_000, XL330)}, out.text
    collided = [f for f in found if f["collision"]]
    assert [(f["id"], f["baudrate"]) for f in collided] == [(6, 57600)], out.text
    assert "two or more servos answer at this ID" in collided[0]["note"]
    old = [f for f in found if f["protocol"] == 1]  # Protocol 1.0: AX at 1 Mbps, MX-28 at 57600 bps from the box
    assert [(f["id"], f["model"], f["model_number"], f["baudrate"]) for f in old] == [
        (7, "AX-12A", AX12, 1_000_000), (8, "MX-28", 29, 57600)]
    assert "init/used_servo_series.AX" in old[0]["note"]   # the handler drives its family with that key
    assert "Firmware Recovery, MX-28(2.0)" in old[1]["note"]
    x = next(f for f in found if f["id"] == 1)
    assert (x["model"], x["mode"], x["torque"], x["hardware_error"]) == ("XM430-W350", "position", False, [])


def test_scan_prints_a_plain_table_when_piped(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM540-W270")
    out = tool(sim, "scan", "--ids", "0-3", "--baud", "57600", "--protocol", "2")
    assert out.returncode == 0, out.text
    lines = out.stdout.splitlines()
    assert lines[0].split()[:3] == ["ID", "model", "number"]
    assert lines[1].split()[:5] == ["1", "XM430-W350", "1020", "48", "57600"]
    assert "\x1b[" not in out.stdout and "2 servo(s) found at 1 baud rate(s)" in out.stdout
    picture = sim.path.replace("/", "_") + ".svg"
    svg = Path(os.environ.get("TMPDIR", "/tmp")) / picture
    out = tool(sim, "scan", "--ids", "0-3", "--baud", "57600", "--protocol", "2", "--svg", str(svg))
    text = svg.read_text()
    svg.unlink()
    assert out.returncode == 0 and text.startswith("<svg") and "XM540-W270" in text, text[:300]
    assert "dynamixel_handler_setup&#160;scan" in text


# ---------------------------------------------------------------------- set-id / set-baud / set
def test_set_id_set_baud_and_a_limit_in_degrees_each_read_back_with_the_sdk(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM540-W270")
    out = tool(sim, "set", "1", "max_position_limit", "170deg", "--yes")
    assert out.returncode == 0, out.text
    # position 0 deg is the middle pulse 2048; 360/4096 deg per pulse (e-Manual, Present Position)
    assert sdk_read(sim.path, 57600, 1, MAX_POSITION_ADDR, 4) == 2048 + round(170 / (360 / 4096))

    out = tool(sim, "set", "1", "max_position_limit", "400deg", "--yes")
    assert out.returncode == 2
    assert "out of range for XM430-W350" in one_error_line(out)
    assert sdk_read(sim.path, 57600, 1, MAX_POSITION_ADDR, 4) == 3982

    out = tool(sim, "set-id", "1", "2", "--yes")
    assert out.returncode == 1 and "ID 2 is already in use" in one_error_line(out)
    assert sdk_ping(sim.path, 57600, 1) == XM430

    out = tool(sim, "set-id", "1", "5", "--yes")
    assert out.returncode == 0, out.text
    assert sdk_ping(sim.path, 57600, 5) == XM430 and sdk_ping(sim.path, 57600, 1) is None

    out = tool(sim, "set-baud", "5", "1000000", "--yes")
    assert out.returncode == 0 and "found again at 1000000 bps" in out.stdout, out.text
    assert sdk_read(sim.path, 1_000_000, 5, BAUD_RATE_ADDR, 1) == 3  # Baud Rate 3 = 1 Mbps
    assert sdk_ping(sim.path, 57600, 5) is None

    # without --baud the tool finds the servo at its new rate; the EEPROM write asks first
    out = tool(sim, "set-mode", "5", "velocity", stdin="n\n")
    assert out.returncode == 1 and "not confirmed: nothing written" in one_error_line(out)
    assert sdk_read(sim.path, 1_000_000, 5, 11, 1) == 3
    out = tool(sim, "set-mode", "5", "velocity", stdin="y\n")
    assert out.returncode == 0, out.text
    assert sdk_read(sim.path, 1_000_000, 5, 11, 1) == 1  # Operating Mode 1 = velocity


def test_an_eeprom_write_turns_torque_off_and_back_on_and_a_value_already_there_is_not_written(sim_of):
    sim = sim_of("1:XM430-W350")
    sdk_write1(sim.path, 57600, 1, 64, 1)  # Torque Enable
    out = tool(sim, "set", "1", "velocity_limit", "120deg/s", "--yes", "--torque-off", "--json")
    assert out.returncode == 0, out.text
    doc = json.loads(out.stdout)
    assert doc["written"] and doc["raw"] == round(120 / (0.229 * 6))  # 0.229 rpm per pulse (e-Manual)
    assert sdk_read(sim.path, 57600, 1, 44, 4) == doc["raw"] and sdk_read(sim.path, 57600, 1, 64, 1) == 1
    again = tool(sim, "set", "1", "velocity_limit", str(doc["raw"]), "--raw", "--yes", "--json")
    assert json.loads(again.stdout)["written"] is False and "nothing written" in again.stderr


def test_torque_comes_back_without_a_move_the_user_did_not_ask_for(sim_of):
    sim = sim_of("1:XM430-W350")
    sdk_write1(sim.path, 57600, 1, 11, 1)  # velocity mode
    sdk_write1(sim.path, 57600, 1, 64, 1)  # torque on
    sdk_write4(sim.path, 57600, 1, 104, 100)  # Goal Velocity: it turns
    out = tool(sim, "set", "1", "velocity_limit", "300", "--raw", "--yes", "--torque-off")
    assert out.returncode == 0, out.text
    assert sdk_read(sim.path, 57600, 1, 64, 1) == 1  # torque back on ...
    assert sdk_read(sim.path, 57600, 1, 104, 4) == 0  # ... at rest, not turning on by itself
    out = tool(sim, "set-mode", "1", "position", "--yes", "--torque-off")
    assert out.returncode == 0, out.text
    present = sdk_read(sim.path, 57600, 1, 132, 4)
    assert sdk_read(sim.path, 57600, 1, 64, 1) == 1
    assert abs(sdk_read(sim.path, 57600, 1, 116, 4) - present) < 20  # Goal Position := where it is
    sdk_write1(sim.path, 57600, 1, 64, 0)
    sdk_write4(sim.path, 57600, 1, 116, (present + 1000) % 4096)  # a goal left from before, far away
    out = tool(sim, "set", "1", "torque_enable", "1")
    assert out.returncode == 0, out.text
    assert abs(sdk_read(sim.path, 57600, 1, 116, 4) - sdk_read(sim.path, 57600, 1, 132, 4)) < 20


# ---------------------------------------------------------------------- assign-ids
def test_assign_ids_gives_three_unboxed_servos_connected_one_after_another_their_own_id_and_rate(sim_of):
    sim = sim_of("20:XM430-W350")
    sdk_write1(sim.path, 57600, 20, BAUD_RATE_ADDR, 3)  # a servo set up earlier: ID 20 at 1 Mbps
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    run = Lines([*cmd, "--device", sim.path, "--latency", "10", "assign-ids", "10", "--baud", "1000000",
                 "--ids", "0-25", "--search-baud", "57600,1000000"])
    try:
        mark = run.wait_for("1 servo(s) already on the bus")
        for k, model in enumerate(("XM430-W350", "XL330-M288", "PH54-200-S500-R")):
            mark = run.wait_for("Connect one new servo and press Enter", mark)
            sim.send(f"add 1 {model}")  # plugged in: ID 1 at 57600 bps as it comes from the box
            time.sleep(0.3)
            run.send("")
            mark = run.wait_for(f"-> ID {10 + k} at 1000000 bps, verified", mark) + 1
        run.wait_for("Connect one new servo", mark)
        run.send("q")
        assert run.proc.wait(20) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    assert {i: sdk_ping(sim.path, 1_000_000, i) for i in (10, 11, 12, 20)} == {10: XM430, 11: XL330, 12: PH54, 20: XM430}
    assert sdk_ping(sim.path, 57600, 1) is None


def test_assign_ids_says_so_when_the_new_servo_arrives_where_a_known_one_is(sim_of):
    sim = sim_of("1:XM430-W350")  # connected before: ID 1 at 57600 bps, where every new servo comes
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    run = Lines([*cmd, "--device", sim.path, "--latency", "10", "assign-ids", "5", "--ids", "0-3",
                 "--search-baud", "57600"])
    try:
        mark = run.wait_for("Connect one new servo and press Enter (it gets ID 5)")
        sim.send("add 1 XL330-M288 --again")
        time.sleep(0.3)
        run.send("")
        mark = run.wait_for("the new servo answers where another one is (ID 1 at 57600 bps)", mark)
        run.send("q")
        assert run.proc.wait(20) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    assert not any("-> ID 5" in line for line in run.lines)  # nothing was written to either of them


# ---------------------------------------------------------------------- backup / reset / restore
def test_backup_also_writes_the_handler_s_servos_block(sim_of, tmp_path):
    import yaml

    from dynamixel_handler.control_table import model_by_number
    from dynamixel_handler.servo.settings import servo_settings
    from dynamixel_handler.servo_targets import refusals
    sim = sim_of("1:XM430-W350", "3:PH54-200-S500-R")
    for args in (("set-mode", "1", "cur_position"), ("set", "1", "velocity_limit", "120deg/s")):
        out = tool(sim, *args, "--yes", "--baud", "57600")
        assert out.returncode == 0, out.text
    block_file = tmp_path / "servos_block.yaml"
    out = tool(sim, "backup", str(tmp_path / "backup.yaml"), "--servos-block", str(block_file), "--baud", "57600")
    assert out.returncode == 0 and f"the servos block of IDs 1, 3 written to {block_file}" in out.stdout, out.text
    block = yaml.safe_load(block_file.read_text())["/**"]["ros__parameters"]["servos"]
    entries = servo_settings(block)
    assert [e.dxl_id for e in entries] == [1, 3]
    assert block["id_1"]["mode"] == "cur_position" and block["id_1"]["velocity_limit_deg_s"] == pytest.approx(120, abs=1)
    assert block["id_1"]["position_p_gain_pulse"] == 800 and "drive_mode" in block["id_3"]
    assert refusals(model_by_number(1020), entries[0]) == [] and refusals(model_by_number(2020), entries[1]) == []


def test_backup_factory_reset_restore_gives_back_the_same_eeprom_bytes(sim_of, tmp_path):
    sim = sim_of("1:XM430-W350", "3:PH54-200-S500-R")
    for args in (("set", "1", "max_position_limit", "170deg"), ("set", "1", "return_delay_time", "20us"),
                 ("set-mode", "1", "ex_position"), ("set", "3", "current_limit", "5A"),
                 ("set", "3", "min_position_limit", "-90deg")):
        out = tool(sim, *args, "--yes", "--baud", "57600")
        assert out.returncode == 0, out.text
    eeprom = {1: (0, 64), 3: (0, 168)}  # the EEPROM areas: X 0..63; P 0..167 (e-Manual control tables)
    before = {i: sdk_bytes(sim.path, 57600, i, a, n) for i, (a, n) in eeprom.items()}
    backup = tmp_path / "servos.yaml"
    out = tool(sim, "backup", str(backup), "--baud", "57600")
    assert out.returncode == 0 and "2 servo(s) saved" in out.stdout, out.text
    assert "max_position_limit: 3982  # 169.98 deg" in backup.read_text()
    for dxl_id in (1, 3):
        out = tool(sim, "factory-reset", str(dxl_id), "--keep", "id,baud", "--yes", "--baud", "57600")
        assert out.returncode == 0, out.text
    after_reset = {i: sdk_bytes(sim.path, 57600, i, a, n) for i, (a, n) in eeprom.items()}
    assert after_reset[1] != before[1] and after_reset[3] != before[3]

    out = tool(sim, "restore", str(backup), "--dry-run", "--baud", "57600", "--json")
    assert out.returncode == 0
    planned = {(c["id"], c["item"]) for c in json.loads(out.stdout)["changes"]}
    assert {(1, "max_position_limit"), (1, "operating_mode"), (3, "current_limit")} <= planned
    assert {i: sdk_bytes(sim.path, 57600, i, a, n) for i, (a, n) in eeprom.items()} == after_reset

    out = tool(sim, "restore", str(backup), "--yes", "--baud", "57600")
    assert out.returncode == 0, out.text
    assert {i: sdk_bytes(sim.path, 57600, i, a, n) for i, (a, n) in eeprom.items()} == before
    out = tool(sim, "restore", str(backup), "--yes", "--baud", "57600")
    assert "every servo already matches" in out.stdout  # nothing written twice (EEPROM wear)

    backup.write_text(backup.read_text().replace("model_number: 1020", "model_number: 1120"))
    out = tool(sim, "restore", str(backup), "--yes", "--baud", "57600")
    assert out.returncode == 2 and "holds a XM540-W270 for ID 1: refused, nothing written" in one_error_line(out)


# ---------------------------------------------------------------------- info, get, monitor, --json
def test_info_get_and_monitor(sim_of):
    sim = sim_of("1:XM430-W350", "2:XM540-W270")
    tool(sim, "set", "1", "max_position_limit", "170deg", "--yes")
    out = tool(sim, "info", "1", "--baud", "57600", "--json")
    items = json.loads(out.stdout)["items"]
    assert items["max_position_limit"]["differs_from_factory"] and items["max_position_limit"]["value"] == pytest.approx(170, abs=0.1)
    assert not items["velocity_limit"]["differs_from_factory"] and items["velocity_limit"]["eeprom"]
    assert not items["present_position"]["eeprom"]
    text = tool(sim, "info", "1", "--baud", "57600").stdout
    assert "EEPROM (written with torque off)" in text and "RAM" in text
    assert [line.split()[-1] for line in text.splitlines() if " max_position_limit " in line] == ["*"]

    out = tool(sim, "get", "2", "present_input_voltage", "--json")
    doc = json.loads(out.stdout)
    assert doc["unit"] == "V" and doc["value"] == pytest.approx(doc["raw"] * 0.1)

    sdk_write1(sim.path, 57600, 2, 65, 1)  # LED on (RAM)
    out = tool(sim, "reboot", "2")
    assert out.returncode == 0 and "ID 2 (XM540-W270) rebooted and answers again" in out.stdout, out.text
    assert sdk_read(sim.path, 57600, 2, 65, 1) == 0  # RAM back to its defaults: it did reboot

    out = tool(sim, "monitor", "--count", "2", "--rate", "10", "--baud", "57600")
    assert out.returncode == 0, out.text
    tables = [t for t in out.stdout.split("\n\n") if t.strip()]
    assert len(tables) == 2 and all(t.splitlines()[0].split()[:3] == ["ID", "model", "position"] for t in tables)
    assert [line.split()[:2] for line in tables[0].splitlines()[1:]] == [["1", "XM430-W350"], ["2", "XM540-W270"]]


def test_bad_arguments_exit_2_with_one_line(sim_of):
    sim = sim_of("1:XM430-W350")
    cases = {("frobnicate",): "invalid choice", ("set-baud", "1", "12345"): "not a Dynamixel baud rate",
             ("set", "1", "no_such_item", "3"): "XM430-W350 has no control-table item 'no_such_item'",
             ("set", "1", "current_limit", "3V"): "current_limit is in mA, not 'V'",
             ("scan", "--ids", "7-300"): "not a list of IDs", ("--baud", "12345", "get", "1", "id"): "not a Dynamixel baud",
             ("factory-reset", "1"): "one of the arguments --keep --all is required",
             ("info", "300"): "'300' is not a servo ID (0..252)", ("--latency", "0", "info", "1"): "not a number above 0",
             ("monitor", "--count", "0"): "not a whole number above 0"}
    for args, text in cases.items():
        out = tool(sim, *args, "--yes")
        assert out.returncode == 2, (args, out.text)
        assert text in one_error_line(out), (args, out.text)
    out = tool(sim, "get", "9", "id", "--baud", "57600")
    assert out.returncode == 1 and "ID 9: no servo answers at 57600 bps" in one_error_line(out)


# ---------------------------------------------------------------------- the port lock
def test_refused_while_a_handler_holds_the_port_and_a_second_handler_fails_at_start(sim_of):
    sim = sim_of("1:XM430-W350")
    params = ("latency_timer:=1", f"device_name:={sim.path}", "baudrate:=57600", "init/servo_auto_search.max_id:=2",
              "init/expected_servo_num:=1", PATIENT_SCAN)  # a busy host: scan again
    node = NodeProcess(node_command(*params))
    try:
        node.wait_for("loop running", timeout=60)
        out = tool(sim, "scan", "--ids", "0-3", "--baud", "57600", "--direct")  # as with no handler found
        assert out.returncode == 1
        line = one_error_line(out)
        assert f"{sim.path} is busy: dynamixel_handler (pid {node.proc.pid}) holds it" in line, line
        assert f"kill {node.proc.pid}" in line
        second = NodeProcess(node_command(*params))
        assert second.wait_exit(60) != 0
        assert f"{sim.path} is busy" in second.output and "Traceback" not in second.output, second.output
    finally:
        node.stop()
    out = tool(sim, "get", "1", "id", "--baud", "57600")  # the handler stopped: the port is free again
    assert out.returncode == 0 and "ID 1 (XM430-W350) id = 1" in out.stdout, out.text


def test_servos_at_one_id_answering_one_after_the_other_are_told_apart(sim_of):
    """Return Delay Times a reply's length apart: the host gets two valid replies for one ping."""
    sim = sim_of("6:XM430-W350", "8:XM430-W350", "2:XM540-W270")
    sdk_write1(sim.path, 57600, 8, 9, 0)  # Return Delay Time 0 (the other keeps 250 = 500 us)
    for dxl_id in (6, 8, 2):
        sdk_write1(sim.path, 57600, dxl_id, BAUD_RATE_ADDR, 3)  # 1 Mbps: a ping reply is 140 us on the wire
    sdk_write1(sim.path, 1_000_000, 8, 7, 6)  # ID 8 -> 6
    out = tool(sim, "scan", "--ids", "0-9", "--baud", "1000000", "--protocol", "2", "--json")
    assert out.returncode == 0, out.text
    found = {f["id"]: f for f in json.loads(out.stdout)["servos"]}
    assert sorted(found) == [2, 6] and found[6]["collision"] and not found[2]["collision"], out.text
    assert found[6]["model_number"] == XM430  # each reply alone is valid: the model is known


def test_monitor_on_a_terminal_is_a_live_table_that_q_quits(sim_of):
    import pty

    sim = sim_of("1:XM430-W350")
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    pid, fd = pty.fork()
    if pid == 0:  # the child: the tool on a terminal
        os.execvpe(cmd[0], [*cmd, "--device", sim.path, "--latency", "10", "monitor", "--baud", "57600"],
                   dict(ENV, COLUMNS="160", LINES="40"))
    screen = b""
    end = time.monotonic() + 30
    while b"XM430-W350" not in screen and time.monotonic() < end - 10:
        screen += _read_some(fd)
    os.write(fd, b"q")
    while time.monotonic() < end:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        screen += _read_some(fd)
    else:
        os.kill(pid, signal.SIGKILL)
        raise AssertionError(f"monitor did not quit on q:\n{screen.decode(errors='replace')}")
    text = screen.decode(errors="replace")
    assert os.waitstatus_to_exitcode(status) == 0, text
    assert "(q quits)" in text and "XM430-W350" in text and "\x1b[" in text  # a rich table, with colours


def _read_some(fd: int) -> bytes:
    import select

    readable, _, _ = select.select([fd], [], [], 0.2)
    try:
        return os.read(fd, 65536) if readable else b""
    except OSError:
        return b""


def test_scan_tells_a_protocol_2_servo_set_to_protocol_type_1_how_to_come_back(sim_of):
    sim = sim_of("1:XM430-W350")
    sdk_write1(sim.path, 57600, 1, 13, 1)  # Protocol Type (13) = 1: it answers Protocol 1.0 only now
    out = tool(sim, "scan", "--ids", "0-3", "--baud", "57600", "--json")
    assert out.returncode == 0, out.text
    found = json.loads(out.stdout)["servos"]
    assert [(f["id"], f["protocol"], f["model"], f["model_number"]) for f in found] == [(1, 1, "XM430-W350", XM430)]
    note = found[0]["note"]
    assert "set to Protocol Type 1" in note and "address 13" in note and "no Protocol 2.0 firmware" not in note
