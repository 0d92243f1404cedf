"""dynamixel_handler_setup on Protocol 1.0 servos (AX-12A, MX-28 and MX-64 with their Protocol 1.0
firmware) and on an X servo switched to Protocol 1.0 and back: every verb run as a process against
the virtual bus run as a process, each result checked with dynamixel_sdk's own PacketHandler(1.0)
(or 2.0 for the switch). Each test gives --baud or IDs, so no test searches every rate but the one
that is about the search for every servo."""
from __future__ import annotations

import json
import sys
import time

import pytest
import test_setup_tool
from dynamixel_sdk import COMM_SUCCESS, PacketHandler
from test_setup_tool import TOOL, Lines, one_error_line, sdk_port, sdk_read, tool

AX12, MX28, MX64, XM430 = 12, 29, 310, 1020
# Protocol 1.0 control table (ROBOTIS e-Manual, AX-12A / MX-28): one layout for the models here
ID, BAUD, RETURN_DELAY, CW_LIMIT, CCW_LIMIT, MAX_VOLTAGE, STATUS_RETURN_LEVEL = 3, 4, 5, 6, 8, 13, 16
TORQUE, LED, GOAL_POSITION, MOVING_SPEED, PRESENT_POSITION = 24, 25, 30, 32, 36
TORQUE_CONTROL = 70  # MX-64: Torque Control Mode Enable
ALARM_LED = 17
PROTOCOL_TYPE = 13  # X series
X_RETURN_DELAY, X_TORQUE = 9, 64  # X series

sim_of = test_setup_tool.sim_of  # the fixture: the virtual bus as a process


def p1_read(path: str, bps: int, dxl_id: int, address: int, size: int) -> int | None:
    """A register read with dynamixel_sdk Protocol 1.0 (None: no reply)."""
    with sdk_port(path, bps) as port:
        data, comm, _err = PacketHandler(1.0).readTxRx(port, dxl_id, address, size)
    return int.from_bytes(bytes(data), "little") if comm == COMM_SUCCESS and len(data) == size else None


def p1_write(path: str, bps: int, dxl_id: int, address: int, value: int, size: int = 1, error: int = 0) -> None:
    """A register write with dynamixel_sdk Protocol 1.0, its status carrying the error bits ``error``."""
    with sdk_port(path, bps) as port:
        comm, err = PacketHandler(1.0).writeTxRx(port, dxl_id, address, size, list(value.to_bytes(size, "little")))
    assert comm == COMM_SUCCESS and err == error, (comm, err)


def p1_ping(path: str, bps: int, dxl_id: int) -> int | None:
    with sdk_port(path, bps) as port:
        model, comm, _err = PacketHandler(1.0).ping(port, dxl_id)
    return model if comm == COMM_SUCCESS else None


def p2_ping(path: str, bps: int, dxl_id: int) -> int | None:
    with sdk_port(path, bps) as port:
        model, comm, _err = PacketHandler(2.0).ping(port, dxl_id)
    return model if comm == COMM_SUCCESS else None


def doc(out) -> dict:
    assert out.returncode == 0, out.text
    return json.loads(out.stdout)


# ---------------------------------------------------------------------- scan, info, get, set
def test_scan_says_what_a_protocol_1_servo_is_and_who_drives_it(sim_of):
    sim = sim_of("1:AX-12A")
    p1_write(sim.path, 1_000_000, 1, TORQUE, 1)
    (ax,) = doc(tool(sim, "scan", "--ids", "0-2", "--baud", "1000000", "--protocol", "1", "--json"))["servos"]
    assert (ax["model"], ax["protocol"], ax["mode"], ax["torque"], ax["hardware_error"]) == ("AX-12A", 1, "position", True, [])
    assert "init/used_servo_series.AX" in ax["note"] and "every verb of this tool reads and writes it" in ax["note"]



def test_info_names_model_firmware_mode_torque_and_the_status_error_bits(sim_of):
    sim = sim_of("1:AX-12A", "2:MX-28(1.0)")
    p1_write(sim.path, 1_000_000, 1, MAX_VOLTAGE, 100, error=1)  # 10.0 V: the 12 V supply is above it
    p1_write(sim.path, 1_000_000, 1, TORQUE, 1, error=1)  # its status says so: input voltage error
    got = doc(tool(sim, "info", "1", "--baud", "1000000", "--json"))
    assert (got["model"], got["model_number"], got["protocol"], got["mode"], got["torque"]) == \
        ("AX-12A", AX12, "1.0", "position", "on")
    assert got["firmware"] > 0 and got["errors"] == ["input_voltage"], got
    items = got["items"]
    assert items["max_position_limit"]["raw"] == p1_read(sim.path, 1_000_000, 1, CCW_LIMIT, 2) == 1023
    assert items["baud_rate"]["text"] == "1,000,000 bps (1)" and items["max_voltage_limit"]["value"] == pytest.approx(10.0)
    assert items["shutdown"]["text"] == "overload, overheating (0x24)"  # the Protocol 1.0 error bits, by name
    p1_write(sim.path, 57600, 2, ALARM_LED, 0x4A)
    out = tool(sim, "get", "2", "alarm_led", "--baud", "57600")
    assert "alarm_led = instruction, range, angle_limit (0x4A)" in out.stdout, out.text
    text = tool(sim, "info", "2", "--baud", "57600").stdout
    assert "ID 2: MX-28 (model 29) at 57600 bps" in text and "protocol 1.0" in text and "mode position" in text
    assert "errors none" in text, text


def test_get_and_set_in_units_and_raw_one_servo_and_several(sim_of):
    sim = sim_of("1:AX-12A", "2:MX-28(1.0)")
    p1_write(sim.path, 1_000_000, 1, BAUD, 34)  # the AX to 57600 bps too: both in one sync write
    out = tool(sim, "set", "1", "goal_position", "30deg", "--baud", "57600")
    assert out.returncode == 0 and "goal_position = 29.91 deg (raw 614)" in out.stdout, out.text
    assert p1_read(sim.path, 57600, 1, GOAL_POSITION, 2) == 614  # 512 + 30 / 0.293
    out = tool(sim, "set", "2", "goal_position", "-90deg", "--baud", "57600")
    assert out.returncode == 0 and p1_read(sim.path, 57600, 2, GOAL_POSITION, 2) == 1024, out.text  # 2048 - 1024
    out = tool(sim, "set", "2", "goal_position", "90", "--baud", "57600")
    assert out.returncode == 2 and "write 90deg, or --raw" in one_error_line(out), out.text
    out = tool(sim, "set", "1", "max_position_limit", "900", "--raw", "--yes", "--baud", "57600")
    assert out.returncode == 0 and p1_read(sim.path, 57600, 1, CCW_LIMIT, 2) == 900, out.text
    got = doc(tool(sim, "get", "1", "max_position_limit", "--baud", "57600", "--json"))
    assert (got["raw"], round(got["value"], 1), got["unit"]) == (900, 113.8, "deg")

    out = tool(sim, "set", "1,2", "led", "1", "--baud", "57600")  # one Protocol 1.0 sync write
    assert out.returncode == 0, out.text
    assert [p1_read(sim.path, 57600, i, LED, 1) for i in (1, 2)] == [1, 1]
    got = doc(tool(sim, "get", "1,2", "present_temperature", "--baud", "57600", "--json"))
    assert [(s["id"], s["model"], s["unit"]) for s in got["servos"]] == [(1, "AX-12A", "degC"), (2, "MX-28", "degC")]


def test_an_eeprom_item_is_written_with_torque_on_and_the_load_kept(sim_of):
    sim = sim_of("1:AX-12A")
    p1_write(sim.path, 1_000_000, 1, TORQUE, 1)
    out = tool(sim, "set", "1", "return_delay_time", "20us", "--yes", "--baud", "1000000")
    assert out.returncode == 0 and "torque was turned off" not in out.stdout, out.text
    assert [p1_read(sim.path, 1_000_000, 1, a, 1) for a in (RETURN_DELAY, TORQUE)] == [10, 1]


def test_a_servo_that_answers_reads_only_is_written_and_read_back(sim_of):
    sim = sim_of("1:AX-12A")
    with sdk_port(sim.path, 1_000_000) as port:  # Status Return Level 1: no status to a write
        assert PacketHandler(1.0).write1ByteTxOnly(port, 1, STATUS_RETURN_LEVEL, 1) == COMM_SUCCESS
    out = tool(sim, "set", "1", "led", "1", "--baud", "1000000")
    assert out.returncode == 0 and "led = 1 (was 0), read back" in out.stdout, out.text
    assert p1_read(sim.path, 1_000_000, 1, LED, 1) == 1
    out = tool(sim, "set", "1", "status_return_level", "2", "--yes", "--baud", "1000000")
    assert out.returncode == 0 and p1_read(sim.path, 1_000_000, 1, STATUS_RETURN_LEVEL, 1) == 2, out.text


# ---------------------------------------------------------------------- assign-ids, set-id, set-baud
def test_assign_ids_gives_unboxed_protocol_1_servos_their_id_and_the_bus_rate(sim_of):
    sim = sim_of("20:XM430-W350")
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    run = Lines([*cmd, "--device", sim.path, "--latency", "10", "assign-ids", "10", "--baud", "57600",
                 "--ids", "0-3", "--search-baud", "57600,1000000", "--protocol", "both"])
    try:
        mark = run.wait_for("0 servo(s) already on the bus")
        for k, model in enumerate(("AX-12A", "MX-28(1.0)")):  # from the box: ID 1 at 1 Mbps / 57600 bps
            mark = run.wait_for("Connect one new servo and press Enter", mark)
            sim.send(f"add 1 {model}")
            time.sleep(0.3)
            run.send("")
            mark = run.wait_for(f"-> ID {10 + k} at 57600 bps, verified", mark) + 1
        run.wait_for("Connect one new servo", mark)
        run.send("q")
        assert run.proc.wait(20) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    assert {i: p1_ping(sim.path, 57600, i) for i in (10, 11)} == {10: AX12, 11: MX28}
    assert p1_ping(sim.path, 1_000_000, 1) is None and p1_ping(sim.path, 57600, 1) is None



def test_set_id_and_set_baud_find_it_again_and_the_rates_the_bus_cannot_open_are_refused(sim_of):
    sim = sim_of("1:AX-12A")
    out = tool(sim, "set-id", "1", "7", "--yes", "--baud", "1000000")
    assert out.returncode == 0 and "answers at ID 7, read back" in out.stdout, out.text
    assert p1_ping(sim.path, 1_000_000, 7) == AX12 and p1_ping(sim.path, 1_000_000, 1) is None
    out = tool(sim, "set-baud", "7", "57600", "--yes", "--baud", "1000000")
    assert out.returncode == 0 and "found again at 57600 bps" in out.stdout, out.text
    assert p1_read(sim.path, 57600, 7, BAUD, 1) == 34  # 2,000,000 / 35 = 57,143 bps
    out = tool(sim, "set-baud", "7", "500000", "--yes", "--baud", "57600")
    assert out.returncode == 2 and "cannot open that rate" in one_error_line(out), out.text
    out = tool(sim, "set-baud", "7", "2000000", "--yes", "--baud", "57600")  # MX only
    assert out.returncode == 2 and "2,000,000/(n+1) bps" in one_error_line(out), out.text
    assert p1_read(sim.path, 57600, 7, BAUD, 1) == 34


# ---------------------------------------------------------------------- set-mode
def test_set_mode_writes_the_angle_limits_and_says_the_joint_limits_it_had(sim_of):
    sim = sim_of("1:AX-12A", "2:MX-28(1.0)", "3:MX-64(1.0)")
    p1_write(sim.path, 1_000_000, 1, CW_LIMIT, 100, 2)
    p1_write(sim.path, 1_000_000, 1, CCW_LIMIT, 900, 2)
    got = doc(tool(sim, "set-mode", "1", "velocity", "--yes", "--baud", "1000000", "--json"))
    assert (got["was"], got["mode"], got["limits_were"], got["limits"]) == ("position", "velocity", [100, 900], [0, 0])
    assert [p1_read(sim.path, 1_000_000, 1, a, 2) for a in (CW_LIMIT, CCW_LIMIT, MOVING_SPEED)] == [0, 0, 0]
    p1_write(sim.path, 1_000_000, 1, MOVING_SPEED, 1024 + 90, 2)  # turning clockwise (bit 10) in Wheel Mode
    out = tool(sim, "set-mode", "1", "position", "--yes", "--baud", "1000000")
    assert out.returncode == 0 and "factory" in out.stdout, out.text
    assert [p1_read(sim.path, 1_000_000, 1, a, 2) for a in (CW_LIMIT, CCW_LIMIT, MOVING_SPEED)] == [0, 1023, 90]
    out = tool(sim, "set-mode", "1", "ex_position", "--baud", "1000000")
    assert out.returncode == 2 and "has no mode 'ex_position'" in one_error_line(out), out.text

    p1_write(sim.path, 57600, 2, TORQUE, 1)  # holding its load: switched only with --torque-off
    out = tool(sim, "set-mode", "2", "ex_position", "--yes", "--baud", "57600")
    assert out.returncode == 2 and "--torque-off" in one_error_line(out), out.text
    assert p1_read(sim.path, 57600, 2, CW_LIMIT, 2) == 0
    out = tool(sim, "set-mode", "2", "ex_position", "--yes", "--torque-off", "--baud", "57600")
    assert out.returncode == 0, out.text
    assert [p1_read(sim.path, 57600, 2, a, 2) for a in (CW_LIMIT, CCW_LIMIT, TORQUE)] == [4095, 4095, 1]

    out = tool(sim, "set-mode", "3", "current", "--yes", "--baud", "57600")
    assert out.returncode == 0 and p1_read(sim.path, 57600, 3, TORQUE_CONTROL, 1) == 1, out.text
    got = doc(tool(sim, "info", "3", "--baud", "57600", "--json"))
    assert got["mode"] == "current"
    out = tool(sim, "set-mode", "3", "position", "--yes", "--baud", "57600")
    assert out.returncode == 0 and p1_read(sim.path, 57600, 3, TORQUE_CONTROL, 1) == 0, out.text


# ---------------------------------------------------------------------- reboot, factory-reset
def test_reboot_says_a_servo_without_the_instruction_must_be_power_cycled(sim_of):
    sim = sim_of("1:AX-12A")
    p1_write(sim.path, 1_000_000, 1, LED, 1)
    out = tool(sim, "reboot", "1", "--baud", "1000000")
    assert out.returncode == 1, out.text
    line = one_error_line(out)
    assert "the AX-12A has no reboot instruction" in line and "power-cycle it" in line, line
    assert p1_read(sim.path, 1_000_000, 1, LED, 1) == 1  # nothing happened to it


def test_factory_reset_finds_it_at_id_1_and_its_factory_rate_and_keeps_what_is_asked(sim_of):
    sim = sim_of("4:AX-12A")
    p1_write(sim.path, 1_000_000, 4, RETURN_DELAY, 10)
    p1_write(sim.path, 1_000_000, 4, BAUD, 34)
    out = tool(sim, "factory-reset", "4", "--keep", "id,baud", "--yes", "--baud", "57600")
    assert out.returncode == 0 and "came back as ID 1 at 1000000 bps" in out.stdout, out.text
    assert "answers at ID 4, 57600 bps" in out.stdout
    assert [p1_read(sim.path, 57600, 4, a, 1) for a in (ID, BAUD, RETURN_DELAY)] == [4, 34, 250]
    got = doc(tool(sim, "factory-reset", "4", "--all", "--yes", "--baud", "57600", "--json"))
    assert (got["id"], got["baudrate"], got["reset_to"]) == (1, 1_000_000, {"id": 1, "baudrate": 1_000_000})
    assert p1_ping(sim.path, 1_000_000, 1) == AX12 and p1_ping(sim.path, 57600, 4) is None


# ---------------------------------------------------------------------- backup, restore, monitor
def test_backup_and_restore_the_eeprom_items(sim_of, tmp_path):
    sim = sim_of("1:AX-12A", "2:MX-28(1.0)")
    p1_write(sim.path, 1_000_000, 1, RETURN_DELAY, 10)
    p1_write(sim.path, 1_000_000, 1, TORQUE, 1)
    file = tmp_path / "backup.yaml"
    out = tool(sim, "backup", str(file), "1,2")
    assert out.returncode == 0 and "2 servo(s) saved" in out.stdout, out.text
    text = file.read_text()
    assert "model: AX-12A" in text and "model: MX-28" in text and "return_delay_time: 10" in text
    p1_write(sim.path, 1_000_000, 1, RETURN_DELAY, 40)
    p1_write(sim.path, 57600, 2, CCW_LIMIT, 3000, 2)
    out = tool(sim, "restore", str(file), "--yes")
    assert out.returncode == 0 and "2 item(s) written and read back" in out.stdout, out.text
    assert p1_read(sim.path, 1_000_000, 1, RETURN_DELAY, 1) == 10 and p1_read(sim.path, 57600, 2, CCW_LIMIT, 2) == 4095
    assert p1_read(sim.path, 1_000_000, 1, TORQUE, 1) == 1  # a Protocol 1.0 model kept its torque


def test_a_restore_file_with_protocol_type_1_needs_force_and_then_finds_the_servo_again(sim_of, tmp_path):
    sim = sim_of("1:XM430-W350")
    file = tmp_path / "backup.yaml"
    assert tool(sim, "backup", str(file), "1", "--baud", "57600").returncode == 0
    text = file.read_text()
    assert "protocol_type: 2\n" in text
    assert "return_delay_time: 250  # 500 us\n" in text
    file.write_text(text.replace("protocol_type: 2\n", "protocol_type: 1\n").replace("return_delay_time: 250 ",
                                                                                    "return_delay_time: 100 "))
    test_setup_tool.sdk_write1(sim.path, 57600, 1, X_TORQUE, 1)  # holding its load
    out = tool(sim, "restore", str(file), "--yes", "--torque-off", "--baud", "57600")
    assert out.returncode == 2 and "answers Protocol 1.0 only" in out.stderr, out.text
    assert "--force writes it anyway" in out.stderr and "refused, nothing written" in out.stderr, out.text
    assert sdk_read(sim.path, 57600, 1, PROTOCOL_TYPE, 1) == 2 and sdk_read(sim.path, 57600, 1, X_RETURN_DELAY, 1) == 250

    out = tool(sim, "restore", str(file), "--yes", "--torque-off", "--force", "--baud", "57600")
    assert out.returncode == 0, out.text
    assert "warning:" in out.stderr and "`set 1 protocol_type 2` brings it back" in out.stderr, out.text
    assert "return_delay_time" in out.stdout and "protocol_type 2 -> 1" in out.stdout, out.text
    # the other item written first, Protocol Type last; found again in Protocol 1.0, torque back on
    assert p2_ping(sim.path, 57600, 1) is None and p1_read(sim.path, 57600, 1, PROTOCOL_TYPE, 1) == 1
    assert p1_read(sim.path, 57600, 1, X_RETURN_DELAY, 1) == 100 and p1_read(sim.path, 57600, 1, X_TORQUE, 1) == 1


def test_restore_onto_the_same_servo_after_a_full_factory_reset(sim_of, tmp_path):
    sim = sim_of("3:AX-12A")
    p1_write(sim.path, 1_000_000, 3, RETURN_DELAY, 10)
    file = tmp_path / "backup.yaml"
    assert tool(sim, "backup", str(file), "3", "--baud", "1000000").returncode == 0
    assert tool(sim, "factory-reset", "3", "--all", "--yes", "--baud", "1000000").returncode == 0
    # ID 3 answers nowhere: every ID is pinged in Protocol 1.0 for its replacement (a shorter wait per ping)
    out = tool(sim, "restore", str(file), "--yes", "--baud", "1000000", "--latency", "4")
    assert out.returncode == 0 and "(replacement): written and read back: id 1 -> 3" in out.stdout, out.text
    assert p1_read(sim.path, 1_000_000, 3, RETURN_DELAY, 1) == 10 and p1_ping(sim.path, 1_000_000, 1) is None


def test_monitor_shows_present_values_in_units(sim_of):
    sim = sim_of("1:AX-12A", "2:MX-28(1.0)")
    p1_write(sim.path, 1_000_000, 1, BAUD, 34)
    p1_write(sim.path, 57600, 2, GOAL_POSITION, 3072, 2)  # +90 deg
    p1_write(sim.path, 57600, 2, TORQUE, 1)
    got = doc(tool(sim, "monitor", "1,2", "--once", "--baud", "57600", "--json"))
    (ax, mx), = got["refreshes"]
    assert (ax["model"], ax["mode"], ax["torque"], mx["torque"]) == ("AX-12A", "position", False, True)
    raw = p1_read(sim.path, 57600, 2, PRESENT_POSITION, 2)
    assert mx["position"] == pytest.approx((raw - 2048) * 360 / 4096, abs=1.0) and mx["temp"] > 0 and mx["voltage"] > 0


def test_the_search_for_every_servo_looks_in_protocol_1_when_asked(sim_of):
    sim = sim_of("1:AX-12A")
    out = tool(sim, "monitor", "--once", "--baud", "1000000")
    assert out.returncode == 1 and "--protocol both" in one_error_line(out), out.text
    got = doc(tool(sim, "monitor", "--once", "--baud", "1000000", "--protocol", "both", "--json"))
    assert [s["model"] for s in got["refreshes"][0]] == ["AX-12A"]


def test_scan_names_two_protocol_1_servos_at_one_id(sim_of):
    """Two AX-12A at ID 3 garble every reply: the scan names the ID shared (it listed neither)."""
    sim = sim_of("1:AX-12A", "3:AX-12A", "3:AX-12A")
    out = tool(sim, "scan", "--ids", "0-4", "--baud", "1000000", "--protocol", "1", "--json")
    assert out.returncode == 0, out.text
    found = {f["id"]: f for f in doc(out)["servos"]}
    assert sorted(found) == [1, 3] and found[3]["collision"] and not found[1]["collision"], out.text
    assert found[3]["protocol"] == 1 and "two or more servos answer at this ID" in found[3]["note"]


# ---------------------------------------------------------------------- Protocol Type
def test_protocol_type_1_and_back_the_round_trip(sim_of, tmp_path):
    sim = sim_of("1:XM430-W350")
    out = tool(sim, "set", "1", "protocol_type", "1", "--yes", "--baud", "57600")
    assert out.returncode == 0 and "it answers Protocol 1.0 now" in out.stdout, out.text
    assert "warning:" in out.stderr and "answers Protocol 1.0 only" in out.stderr, out.text
    assert p2_ping(sim.path, 57600, 1) is None and p1_read(sim.path, 57600, 1, PROTOCOL_TYPE, 1) == 1
    out = tool(sim, "scan", "--ids", "0-2", "--baud", "57600", "--json")
    (found,) = doc(out)["servos"]
    assert (found["protocol"], found["model"]) == (1, "XM430-W350") and "set 1 protocol_type 2" in found["note"]
    firmware = p1_read(sim.path, 57600, 1, 6, 1)  # Firmware Version is at 6 in the X table, not 2 as on a 1.0 model
    assert found["firmware"] == firmware > 0, found
    assert tool(sim, "backup", str(tmp_path / "b.yaml"), "1", "--baud", "57600").returncode == 0
    assert f"firmware: {firmware}\n" in (tmp_path / "b.yaml").read_text()
    got = doc(tool(sim, "get", "1", "protocol_type", "--baud", "57600", "--json"))
    assert got["raw"] == 1
    out = tool(sim, "set", "1", "protocol_type", "2", "--yes", "--baud", "57600")
    assert out.returncode == 0 and "it answers Protocol 2.0 now" in out.stdout, out.text
    assert p2_ping(sim.path, 57600, 1) == XM430 and sdk_read(sim.path, 57600, 1, PROTOCOL_TYPE, 1) == 2
