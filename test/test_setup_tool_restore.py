"""dynamixel_handler_setup restore onto a replacement servo, with one servo missing, with a servo
moved to another rate since the backup, and with files that must be refused before anything is
written (a YAML bomb, a FIFO, deep nesting, values out of range). The tool and the virtual bus run
as processes; every servo's EEPROM is read back with dynamixel_sdk."""
from __future__ import annotations

import json
import os
import signal

import pytest
from test_setup_tool import BAUD_RATE_ADDR, MAX_POSITION_ADDR, XM540, Sim, sdk_bytes, sdk_ping, sdk_read, sdk_write1, sdk_write4
from test_setup_tool import tool as _tool
from test_setup_tool_safety import Paused

RETURN_DELAY, TEMPERATURE_LIMIT, TORQUE = 9, 31, 64  # X series (ROBOTIS e-Manual)
EEPROM = (0, 64)  # X series EEPROM area



def tool(sim: Sim, *args: str, stdin: str = "", timeout: float = 60.0):
    """The tool as a process, with reply timeouts and retries for a loaded host (a 30 ms latency timer, 2 retries)."""
    return _tool(sim, *args, "--latency", "30", "--retries", "2", stdin=stdin, timeout=timeout)


@pytest.fixture
def bus(tmp_path):
    started: list[Sim] = []

    def start(*servos: str) -> Sim:
        sim = Sim(tmp_path / "bus.json", *servos)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.stop()


def _eeprom(sim: Sim, bps: int, dxl_id: int) -> bytes | None:
    """The servo's EEPROM area, asked up to three times (a loaded host may hold the bus's reply back)."""
    for _ in range(3):
        got = sdk_bytes(sim.path, bps, dxl_id, *EEPROM)
        if got is not None:
            return got
    return None


def test_restore_gives_a_factory_reset_replacement_its_id_rate_and_items(bus, tmp_path):
    sim = bus("1:XM430-W350", "3:XM540-W270", "5:XL330-M288")
    for dxl_id in (1, 3):
        sdk_write1(sim.path, 57600, dxl_id, BAUD_RATE_ADDR, 3)  # IDs 1 and 3 at 1 Mbps, ID 5 at 57600
    sdk_write4(sim.path, 1_000_000, 3, MAX_POSITION_ADDR, 3072)  # 90 deg
    sdk_write1(sim.path, 1_000_000, 3, RETURN_DELAY, 10)
    before = _eeprom(sim, 1_000_000, 3)
    backup = tmp_path / "robot.yaml"
    out = tool(sim, "backup", str(backup), "1,3,5")  # IDs given: the search ends at the rate of the last
    assert out.returncode == 0 and "3 servo(s) saved" in out.stdout, out.text

    out = tool(sim, "factory-reset", "3", "--all", "--yes", "--baud", "57600,1M")  # the replacement: ID 1 at 57600 bps
    assert out.returncode == 0, out.text
    assert sdk_ping(sim.path, 57600, 1) == XM540 and sdk_ping(sim.path, 1_000_000, 3) is None

    out = tool(sim, "restore", str(backup), "--dry-run", "--json", "--baud", "57600,1M")  # the rates used
    assert out.returncode == 0, out.text
    planned = json.loads(out.stdout)
    three = next(s for s in planned["servos"] if s["id"] == 3)
    assert three["replacement"] and three["found_at"] == {"id": 1, "baudrate": 57600}, out.stdout
    assert [w["item"] for w in three["writes"]] == ["id", "baud_rate", "return_delay_time", "max_position_limit"]
    assert [c["item"] for c in planned["changes"]] == [w["item"] for w in three["writes"]]  # nothing else changes
    assert sdk_ping(sim.path, 57600, 1) == XM540  # the dry run wrote nothing

    out = tool(sim, "restore", str(backup), "--yes", "--json", "--baud", "57600,1M")
    assert out.returncode == 0, out.text
    done = next(s for s in json.loads(out.stdout)["servos"] if s["id"] == 3)
    assert [w.split()[0] for w in done["written"]] == [w["item"] for w in three["writes"]]  # what the dry run said
    assert _eeprom(sim, 1_000_000, 3) == before
    assert sdk_ping(sim.path, 57600, 1) is None and sdk_ping(sim.path, 1_000_000, 1) is not None


def test_one_missing_servo_is_reported_and_the_others_restored_at_their_rates(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM430-W350", "4:XM540-W270")
    backup = tmp_path / "robot.yaml"
    out = tool(sim, "backup", str(backup), "--baud", "57600")
    assert out.returncode == 0, out.text
    before = {i: _eeprom(sim, 57600, i) for i in (1, 2)}
    sim.send("remove 4")  # unplugged: no XM540 left to take its place
    sdk_write1(sim.path, 57600, 1, TEMPERATURE_LIMIT, 70)
    sdk_write1(sim.path, 57600, 2, RETURN_DELAY, 0)
    sdk_write1(sim.path, 57600, 2, BAUD_RATE_ADDR, 3)  # ID 2 moved to 1 Mbps since the backup

    out = tool(sim, "restore", str(backup), "--dry-run", "--json", "--baud", "57600,1M")
    assert out.returncode == 1, out.text  # as the real run will: ID 4 cannot be restored
    assert "the real run would be incomplete" in out.stderr and "ID 4 (XM540-W270) answers at no rate" in out.stderr
    planned = {c["id"]: [] for c in json.loads(out.stdout)["changes"]}
    for c in json.loads(out.stdout)["changes"]:
        planned[c["id"]].append(c["item"])
    assert planned == {1: ["temperature_limit"], 2: ["baud_rate", "return_delay_time"]}, out.stdout

    out = tool(sim, "restore", str(backup), "--yes", "--baud", "57600,1M")
    assert out.returncode == 1, out.text
    assert "ID 4 (XM540-W270) answers at no rate" in out.stderr and "3 item(s) written and read back" in out.stderr
    assert {i: _eeprom(sim, 57600, i) for i in (1, 2)} == before
    assert "temperature_limit" in out.stdout and "baud_rate 1,000,000 bps (3) -> 57,600 bps (1)" in out.stdout


def test_a_servo_holding_its_load_is_not_let_go_without_torque_off(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM540-W270")
    backup = tmp_path / "robot.yaml"
    assert tool(sim, "backup", str(backup), "--baud", "57600").returncode == 0
    sdk_write1(sim.path, 57600, 1, TEMPERATURE_LIMIT, 70)
    sdk_write1(sim.path, 57600, 2, TEMPERATURE_LIMIT, 70)
    sdk_write1(sim.path, 57600, 2, TORQUE, 1)
    out = tool(sim, "restore", str(backup), "--yes")
    assert out.returncode == 2 and "torque is on" in out.stderr and "refused, nothing written" in out.stderr, out.text
    assert sdk_read(sim.path, 57600, 1, TEMPERATURE_LIMIT, 1) == 70  # not even the other servo's item
    out = tool(sim, "restore", str(backup), "--torque-off", "--baud", "57600", stdin="n\n")  # asked, declined
    assert out.returncode == 1 and "write these 2 EEPROM item(s)?" in out.stdout, out.text
    assert "not confirmed: nothing written" in out.stderr, out.text
    assert [sdk_read(sim.path, 57600, i, TEMPERATURE_LIMIT, 1) for i in (1, 2)] == [70, 70]
    out = tool(sim, "restore", str(backup), "--yes", "--torque-off")
    assert out.returncode == 0, out.text
    assert [sdk_read(sim.path, 57600, i, TEMPERATURE_LIMIT, 1) for i in (1, 2)] == [80, 80]
    assert sdk_read(sim.path, 57600, 2, TORQUE, 1) == 1  # torque back on after its writes


def test_files_that_are_not_backups_are_refused_before_anything_is_written(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM540-W270")
    backup = tmp_path / "robot.yaml"
    assert tool(sim, "backup", str(backup), "--baud", "57600").returncode == 0
    sdk_write1(sim.path, 57600, 1, RETURN_DELAY, 0)
    text = backup.read_text()
    lines = ["a: &a [x, x, x, x, x, x, x, x, x]"] + [
        f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join([f'*{chr(97 + k)}'] * 9)}]" for k in range(8)]
    cases = {
        "bomb.yaml": ("\n".join(lines + ["servos: *i"]) + "\n", "anchors or aliases"),
        "deep.yaml": ("servos:\n  1:\n    eeprom: " + "[" * 50 + "]" * 50 + "\n", "nests deeper"),
        "hot.yaml": (text.replace("temperature_limit: 80", "temperature_limit: 150", 1), "temperature_limit = 150 degC"),
        "inverted.yaml": (text.replace("max_position_limit: 4095", "max_position_limit: 0", 1), "would not be below"),
        "strange.yaml": (text.replace("drive_mode: 0", "drive_mode: lots", 1), "is not a raw value"),
    }
    for name, (body, why) in cases.items():
        (tmp_path / name).write_text(body)
        out = tool(sim, "restore", str(tmp_path / name), "--yes", timeout=30)
        lines_out = [line for line in out.stderr.splitlines() if line.strip()]
        assert out.returncode == 2 and len(lines_out) == 1 and why in lines_out[0], (name, out.text)
    deep = tmp_path / ("robot_backups_" * 8) / "missing.yaml"  # named whole, not cut to a stem
    out = tool(sim, "restore", str(deep), "--yes", timeout=30)
    assert out.returncode == 2 and f"cannot read {deep}: No such file" in out.stderr, out.text
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    out = tool(sim, "restore", str(fifo), "--yes", timeout=30)
    assert out.returncode == 2 and "is a FIFO, not a backup file" in out.stderr, out.text
    assert sdk_read(sim.path, 57600, 1, RETURN_DELAY, 1) == 0  # nothing of any file was written


def test_a_signal_after_each_bus_instruction_of_a_restore_leaves_each_servo_whole_and_named(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM540-W270")
    backup = tmp_path / "robot.yaml"
    assert tool(sim, "backup", str(backup), "--baud", "57600").returncode == 0
    restored = {i: _eeprom(sim, 57600, i) for i in (1, 2)}
    stops = 0
    for after in range(0, 80):
        signum = (signal.SIGINT, signal.SIGTERM)[after % 2]  # both signals, each at every other point
        name = signal.Signals(signum).name
        for dxl_id in (1, 2):  # both changed since the backup; ID 1 holds its load
            sdk_write1(sim.path, 57600, dxl_id, TORQUE, 0)
            sdk_write1(sim.path, 57600, dxl_id, TEMPERATURE_LIMIT, 70)
            sdk_write1(sim.path, 57600, dxl_id, RETURN_DELAY, 5)
        changed = {i: _eeprom(sim, 57600, i) for i in (1, 2)}
        sdk_write1(sim.path, 57600, 1, TORQUE, 1)
        run = Paused(sim, after, "restore", str(backup), "--yes", "--torque-off", "--baud", "57600")
        if not run.paused():
            code, text = run.finish()
            assert code == 0 and {i: _eeprom(sim, 57600, i) for i in (1, 2)} == restored, text
            break
        run.proc.send_signal(signum)
        code, text = run.finish()
        stops += 1
        assert code == 130 and f"interrupted ({name})" in text and "Traceback" not in text, (after, text)
        assert sdk_read(sim.path, 57600, 1, TORQUE, 1) == 1 and sdk_read(sim.path, 57600, 2, TORQUE, 1) == 0, (after, text)
        for dxl_id, model in ((1, "XM430-W350"), (2, "XM540-W270")):
            now = _eeprom(sim, 57600, dxl_id)
            assert now in (restored[dxl_id], changed[dxl_id]), (after, dxl_id, text)  # never half written
            said = f"ID {dxl_id} ({model}) at 57600 bps" in text and "temperature_limit" in text
            assert said == (now == restored[dxl_id]), (after, dxl_id, text)  # written exactly when the output says so
    else:
        raise AssertionError("the restore never ended without a pause")
    assert stops >= 10, stops
