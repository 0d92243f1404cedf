"""dynamixel_handler_setup reaches every servo: every verb looks at every rate without --baud (one
search), a list of IDs names each missing one and does the others; values read by name (codes, bit
masks, digits); one JSON shape for a servo; --trace shows each packet; monitor --log / --plot and
the plot verb. The tool runs as a process against the virtual bus run as a process; each result is
checked against the registers read with dynamixel_sdk."""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import time

import pytest
from test_setup_tool import BAUD_RATE_ADDR, ENV, ROOT, TOOL, XL330, XM430, XM540, Sim, sdk_ping, sdk_read, sdk_write1, sdk_write4
from test_setup_tool import tool as _tool

LED, HW_ERROR, GOAL_POSITION, PRESENT_POSITION = 65, 70, 116, 132  # X series (ROBOTIS e-Manual)



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


def _three_at_two_rates(bus) -> Sim:
    """ID 1 (XM430) and 5 (XL330) at 57600 bps, ID 3 (XM540) at 1 Mbps."""
    sim = bus("1:XM430-W350", "3:XM540-W270", "5:XL330-M288")
    sdk_write1(sim.path, 57600, 3, BAUD_RATE_ADDR, 3)
    return sim


def _keys(doc: object) -> set[str]:
    if isinstance(doc, dict):
        return set(doc) | {k for v in doc.values() for k in _keys(v)}
    if isinstance(doc, list):
        return {k for v in doc for k in _keys(v)}
    return set()


# ---------------------------------------------------------------------- one search, every verb
def test_monitor_finds_servos_at_every_rate_without_baud_and_a_baud_list_bounds_every_search(bus, tmp_path):
    """Without --baud every rate is looked at; with a list (backup, reboot all) those rates only, and
    a servo at a rate the list leaves out is not found."""
    sim = _three_at_two_rates(bus)
    out = tool(sim, "monitor", "--once", "--json")
    assert out.returncode == 0, out.text
    rows = json.loads(out.stdout)["refreshes"][0]
    assert {(r["id"], r["model_number"], r["baudrate"]) for r in rows} == {
        (1, XM430, 57600), (3, XM540, 1_000_000), (5, XL330, 57600)}, out.text
    present = sdk_read(sim.path, 1_000_000, 3, PRESENT_POSITION, 4)
    assert next(r for r in rows if r["id"] == 3)["position"] == pytest.approx((present - 2048) * 360 / 4096, abs=0.1)

    backup = tmp_path / "all.yaml"
    out = tool(sim, "backup", str(backup), "--baud", "1M,57600")
    assert out.returncode == 0 and "3 servo(s) saved" in out.stdout, out.text
    text = backup.read_text()
    assert "  3:\n    model: XM540-W270\n    model_number: 1120\n    baudrate: 1000000\n" in text
    assert sdk_read(sim.path, 1_000_000, 3, BAUD_RATE_ADDR, 1) == 3

    for dxl_id, bps in ((1, 57600), (3, 1_000_000), (5, 57600)):
        sdk_write1(sim.path, bps, dxl_id, LED, 1)  # LED on (RAM): a reboot clears it
    out = tool(sim, "reboot", "all", "--json", "--baud", "1M,2M")  # only ID 3 is at one of these
    assert out.returncode == 0, out.text
    assert sorted(json.loads(out.stdout)["rebooted"]) == [3]
    assert [sdk_read(sim.path, bps, i, LED, 1) for i, bps in ((1, 57600), (3, 1_000_000), (5, 57600))] == [1, 0, 1]
    out = tool(sim, "reboot", "all", "--json", "--baud", "57600,1M")
    assert out.returncode == 0, out.text
    assert sorted(json.loads(out.stdout)["rebooted"]) == [1, 3, 5]
    assert [sdk_read(sim.path, bps, i, LED, 1) for i, bps in ((1, 57600), (3, 1_000_000), (5, 57600))] == [0, 0, 0]


def test_a_list_of_ids_names_each_missing_one_and_does_the_others(bus, tmp_path):
    sim = _three_at_two_rates(bus)
    out = tool(sim, "monitor", "1,3,7", "--once", "--json", "--baud", "57600,1M")
    assert out.returncode == 1, out.text
    doc = json.loads(out.stdout)
    assert [r["id"] for r in doc["refreshes"][0]] == [1, 3] and doc["missing"] == [7]
    assert "ID 7: no servo answers at any baud rate (57600, 1000000 bps)" in out.stderr, out.text
    assert "1 of 3 servo(s) not found (ID 7)" in out.stderr

    sdk_write1(sim.path, 57600, 1, LED, 1)
    sdk_write1(sim.path, 1_000_000, 3, LED, 1)
    out = tool(sim, "reboot", "9,1,3")
    assert out.returncode == 1 and "ID 9: no servo answers at any baud rate" in out.stderr, out.text
    assert "ID 1 (XM430-W350) rebooted" in out.stdout and "ID 3 (XM540-W270) rebooted" in out.stdout
    assert sdk_read(sim.path, 57600, 1, LED, 1) == 0 and sdk_read(sim.path, 1_000_000, 3, LED, 1) == 0

    backup = tmp_path / "some.yaml"
    out = tool(sim, "backup", str(backup), "3,4")
    assert out.returncode == 1 and "ID 4: no servo answers" in out.stderr, out.text
    assert "  3:\n    model: XM540-W270" in backup.read_text() and "  4:" not in backup.read_text()


# ---------------------------------------------------------------------- values and JSON
def test_codes_bits_and_numbers_are_read_by_name(bus):
    sim = bus("1:XM430-W350", "2:PH54-200-S500-R")
    sdk_write1(sim.path, 57600, 2, 8, 3)  # P series Baud Rate (8) = 3: 1 Mbps
    sim.send("hwerr 1 0x24")
    end = time.monotonic() + 10
    while sdk_read(sim.path, 57600, 1, HW_ERROR, 1) != 0x24 and time.monotonic() < end:
        time.sleep(0.05)
    assert sdk_read(sim.path, 57600, 1, HW_ERROR, 1) == 0x24  # bits 2 and 5: overheating, overload
    rate = {"1": "57600", "2": "1000000"}  # where each is: values by name, not the search, are this test's
    shown = {args: tool(sim, "get", *args, "--baud", rate[args[0]]).stdout.strip() for args in (
        ("1", "hardware_error_status"), ("2", "baud_rate"), ("1", "operating_mode"), ("2", "current_limit"))}
    assert shown[("1", "hardware_error_status")].endswith("hardware_error_status = overload, overheating (0x24)")
    assert shown[("2", "baud_rate")].endswith("baud_rate = 1,000,000 bps (3)")
    assert shown[("1", "operating_mode")].endswith("operating_mode = position (3)")
    table = {line.split()[1]: line for line in tool(sim, "info", "1", "--baud", "57600").stdout.splitlines() if line[:1].isdigit()}
    assert sdk_read(sim.path, 57600, 1, 63, 1) == 0x34  # Shutdown: overload, electrical shock, overheating
    assert "overload, electrical_shock, overheating" in table["shutdown"] and "57,600 bps" in table["baud_rate"]
    assert table["operating_mode"].split()[2] == "position" and "overload, overheating" in table["hardware_error_status"]
    raw = sdk_read(sim.path, 1_000_000, 2, 38, 2)  # P series Current Limit (38): 1 mA per unit
    limit = shown[("2", "current_limit")]
    assert "e+" not in limit and limit.endswith(f"current_limit = {raw:,} mA (raw {raw})"), limit


def test_every_verb_names_a_servo_by_id_in_one_json_shape(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM540-W270")
    backup = tmp_path / "b.yaml"
    runs = [("scan", "--ids", "0-3", "--protocol", "2"), ("get", "1", "id"), ("monitor", "--once"),
            ("backup", str(backup)), ("restore", str(backup), "--dry-run"), ("reboot", "1,2")]
    for args in runs:  # where the servos are: the search at every rate is the first test's
        out = tool(sim, *args, "--json", "--baud", "57600")
        assert out.returncode == 0, (args, out.text)
        doc = json.loads(out.stdout)
        assert "dxl_id" not in _keys(doc), (args, out.stdout)
        servos = doc.get("servos") or doc.get("refreshes", [[]])[0]
        if args[0] != "get":
            assert sorted(s["id"] for s in servos) == [1, 2], (args, out.stdout)
            assert all({"id", "model", "model_number", "baudrate"} <= set(s) for s in servos), (args, out.stdout)
    assert sdk_ping(sim.path, 57600, 1) == XM430 and sdk_ping(sim.path, 57600, 2) == XM540
    for args in (("info", "1"), ("get", "1", "id"), ("set", "1", "led", "1"), ("set-mode", "1", "velocity"),
                 ("set-id", "1", "4"), ("set-baud", "4", "1M"), ("factory-reset", "4", "--keep", "id,baud")):
        bps = "1000000" if args[0] == "factory-reset" else "57600"  # after set-baud, ID 4 is at 1 Mbps
        out = tool(sim, *args, "--json", "--yes", "--baud", bps)
        assert out.returncode == 0, (args, out.text)
        doc = json.loads(out.stdout)
        assert "dxl_id" not in _keys(doc) and doc["model"] == "XM430-W350" and doc["model_number"] == XM430, (args, doc)
        assert doc["id"] in (1, 4) and doc["baudrate"] in (57600, 1_000_000), (args, doc)
    assert sdk_ping(sim.path, 1_000_000, 4) == XM430


# ---------------------------------------------------------------------- --trace
def test_trace_prints_each_instruction_and_status_with_time_hex_and_meaning(bus):
    sim = bus("1:XM430-W350")
    sdk_write4(sim.path, 57600, 1, GOAL_POSITION, 3000)
    out = tool(sim, "get", "1", "goal_position", "--baud", "57600", "--trace")
    assert out.returncode == 0, out.text
    packets = [line.split() for line in out.stderr.splitlines() if line.split()[1:2] in (["<"], [">"])]
    times = [float(p[0]) for p in packets]
    assert times == sorted(times) and len(packets) >= 4, out.stderr
    sent = [" ".join(p) for p in packets if p[1] == ">"]
    back = [" ".join(p) for p in packets if p[1] == "<"]
    # READ (0x02) of 4 bytes at 116 (0x74) from ID 1: FF FF FD 00 | 01 | 07 00 | 02 | 74 00 04 00 | CRC
    assert any("> FF FF FD 00 01 07 00 02 74 00 04 00" in s and s.endswith("read ID 1 @116 x4 (goal_position)")
               for s in sent), out.stderr
    assert any("ping ID 1" in s for s in sent)
    assert any(b.endswith(f"status ID 1 ok: {sdk_read(sim.path, 57600, 1, GOAL_POSITION, 4)} (goal_position)")
               for b in back), out.stderr
    assert any("status ID 1 ok: model 1020 (XM430-W350), firmware" in b for b in back)
    assert "goal_position = " in out.stdout  # the verb's own output stays on stdout


def test_trace_decodes_protocol_1_packets_too(bus):
    sim = bus("3:AX-12A")  # Protocol 1.0, 1 Mbps from the factory
    out = tool(sim, "scan", "--ids", "3", "--baud", "1000000", "--protocol", "1", "--trace")
    assert out.returncode == 0, out.text
    lines = out.stderr.splitlines()
    assert any(line.endswith("Protocol 1.0 ping ID 3") and "> FF FF 03 02 01 F9" in line for line in lines), out.stderr
    assert any(line.endswith("Protocol 1.0 status ID 3 no error") for line in lines), out.stderr
    assert any(line.endswith("Protocol 1.0 status ID 3 no error: model 12 (AX-12A)") for line in lines), out.stderr
    # the firmware, read as the model's item (address 2 on a Protocol 1.0 model)
    read_at_2 = next(k for k, line in enumerate(lines) if line.endswith("Protocol 1.0 read ID 3 @2 x1"))
    assert lines[read_at_2 + 1].endswith("Protocol 1.0 status ID 3 no error: 24 (firmware_version)"), out.stderr
    assert any(line.endswith("no error: 1023 (max_position_limit)") for line in lines), out.stderr  # by its item


# ---------------------------------------------------------------------- --log, --plot, plot
def test_monitor_logs_csv_rows_and_plots_goal_against_present(bus, tmp_path):
    sim = bus("1:XM430-W350", "2:XM540-W270")
    sdk_write1(sim.path, 57600, 1, 64, 1)  # torque on, then a goal: it moves toward it
    sdk_write4(sim.path, 57600, 1, GOAL_POSITION, 3072)  # 90 deg
    log, picture = tmp_path / "m.csv", tmp_path / "m.svg"
    out = tool(sim, "monitor", "--count", "4", "--rate", "10", "--log", str(log), "--plot", str(picture),
               "position,current", "--baud", "57600")
    assert out.returncode == 0, out.text
    rows = list(csv.DictReader(log.open()))
    assert len(rows) == 8 and [r["id"] for r in rows[:2]] == ["1", "2"]
    stamps = [float(r["time_s"]) for r in rows]
    assert stamps == sorted(stamps) and stamps[0] == 0.0 and stamps[-1] > 0
    assert all(float(r["goal_position_deg"]) == pytest.approx(90, abs=0.1) for r in rows if r["id"] == "1"), rows
    assert {r["model"] for r in rows} == {"XM430-W350", "XM540-W270"} and all(r["utc"].endswith("+00:00") for r in rows)
    svg = picture.read_text()
    assert "<svg" in svg and "position" in svg and "current" in svg, svg[:300]

    again, fifo = tmp_path / "p.svg", tmp_path / "fifo"
    os.mkfifo(fifo)  # opened, it would wait for the other end: refused instead
    out = tool(sim, "plot", str(log), str(again), "velocity")
    assert out.returncode == 0 and again.read_text().lstrip().startswith("<?xml"), out.text
    for args in (("plot", str(log), str(tmp_path / "no" / "such" / "dir.svg")),
                 ("monitor", "--once", "--baud", "57600", "--log", str(tmp_path / "no" / "x.csv")),
                 ("monitor", "--once", "--baud", "57600", "--plot", str(tmp_path / "no" / "x.svg")),
                 ("plot", str(tmp_path / "missing.csv"), str(again)),
                 ("plot", str(log), str(again), "torque_of_the_moon"), ("plot", str(fifo), str(again)),
                 ("monitor", "--once", "--baud", "57600", "--log", str(fifo)), ("backup", str(fifo), "--baud", "57600")):
        out = tool(sim, *args)
        lines = [line for line in out.stderr.splitlines() if line.strip()]
        assert out.returncode in (1, 2) and len(lines) == 1 and lines[0].startswith("error: "), (args, out.text)


def test_messages_name_the_tools_own_option_for_the_device(bus, tmp_path):
    sim = bus("1:XM430-W350")
    for device in (str(tmp_path / "ttyNONE"), "/etc/hostname", "serial:NOSUCH"):
        out = tool(sim, "get", "1", "id", "--device", device)
        assert out.returncode == 1 and "--device" in out.stderr and "device_name" not in out.stderr, out.text



# ---------------------------------------------------------------------- several servos at once
#: the servos of these tests are at these rates: a search of every rate would only add time
TWO_RATES = ("--baud", "57600,1M")


def test_set_get_and_set_mode_of_several_servos_in_one_sync_write_and_read(bus):
    sim = bus("1:XM430-W350", "2:XM540-W270", "5:XL330-M288")
    sdk_write1(sim.path, 57600, 5, BAUD_RATE_ADDR, 3)  # ID 5 at 1 Mbps
    out = tool(sim, "set", "1,2,5", "profile_velocity", "30rpm", "--trace", *TWO_RATES)
    assert out.returncode == 0, out.text
    writes = [line for line in out.stderr.splitlines() if "sync_write @112 x4 (profile_velocity)" in line]
    assert [w.split("(profile_velocity) ")[1] for w in writes] == ["1=131, 2=131", "5=131"], out.stderr  # one per rate
    assert not any(" write ID" in line for line in out.stderr.splitlines()), out.stderr
    raw = round(30 / 0.229)  # 0.229 rpm per unit (e-Manual, Profile Velocity)
    assert [sdk_read(sim.path, bps, i, 112, 4) for i, bps in ((1, 57600), (2, 57600), (5, 1_000_000))] == [raw] * 3
    assert [line.split(" = ")[0] for line in out.stdout.splitlines()] == [
        "ID 1 (XM430-W350) profile_velocity", "ID 2 (XM540-W270) profile_velocity", "ID 5 (XL330-M288) profile_velocity"]

    out = tool(sim, "get", "1,2,5,9", "profile_velocity", "--json", "--trace", *TWO_RATES)
    assert out.returncode == 1 and "ID 9: no servo answers" in out.stderr, out.text
    doc = json.loads(out.stdout)
    assert [(s["id"], s["raw"], s["baudrate"]) for s in doc["servos"]] == [(1, raw, 57600), (2, raw, 57600), (5, raw, 1_000_000)]
    assert doc["missing"] == [9] and sum("sync_read @112" in line for line in out.stderr.splitlines()) == 2

    sdk_write1(sim.path, 57600, 2, 64, 1)  # ID 2 holds its load
    out = tool(sim, "set-mode", "1,2", "velocity", "--yes", *TWO_RATES)
    assert out.returncode == 2 and "torque is on" in out.stderr, out.text
    assert [sdk_read(sim.path, 57600, i, 11, 1) for i in (1, 2)] == [3, 3]  # nothing written to either
    out = tool(sim, "set-mode", "1,2", "velocity", "--yes", "--torque-off", *TWO_RATES)
    assert out.returncode == 0, out.text
    assert [sdk_read(sim.path, 57600, i, 11, 1) for i in (1, 2)] == [1, 1]  # Operating Mode 1 = velocity
    assert sdk_read(sim.path, 57600, 2, 64, 1) == 1 and sdk_read(sim.path, 57600, 1, 64, 1) == 0  # torque as before


def test_monitor_shows_a_missing_id_and_takes_it_in_once_it_is_plugged_in(bus):
    sim = bus("1:XM430-W350")
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    run = subprocess.Popen([*cmd, "--device", sim.path, "--latency", "30", "monitor", "1,2", "--baud", "57600",
                            "--count", "30", "--rate", "5", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, env=ENV, cwd=ROOT)
    time.sleep(1.0)
    sim.send("add 2 XM540-W270")  # plugged in while the table runs
    out, err = run.communicate(timeout=60)
    assert run.returncode == 0 and "Traceback" not in err, out + err
    doc = json.loads(out)
    assert "ID 2: no servo answers at 57600 bps" in err  # said once, at the start
    assert [r["id"] for r in doc["refreshes"][0]] == [1] and doc["missing"] == []
    assert [(r["id"], r["model"]) for r in doc["refreshes"][-1]] == [(1, "XM430-W350"), (2, "XM540-W270")]
