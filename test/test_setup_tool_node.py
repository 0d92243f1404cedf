"""The set-up tool on a port a running handler holds: the real node on the virtual bus, the real
tool process. ``get``, ``set``, ``info``, ``backup``, ``monitor``, ``set-mode``, ``reboot`` and
``restore`` go through the node (values read back on the virtual servos, the line that says so,
``--json``, the checks' refusals and exit codes), a verb that changes the bus is refused with what
to do, ``--direct`` is refused as before, a ``get`` while the adapter is gone is one clear line
within seconds, and a stale owner record is ignored."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dynamixel_handler.bus.owner_record import find_owner

from support.rig import Rig

ROOT = Path(__file__).resolve().parent.parent
TOOL = shutil.which("dynamixel_handler_setup")
XM430 = 1020
THROUGH = "through the running node /dynamixel_handler"


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: XM430, 2: XM430}, "baudrate:=1000000", sim_kwargs={"baudrate": 1_000_000})
    yield r
    assert r.close() == 0


def tool(rig, *args: str, stdin: str = "", timeout: float = 60.0) -> subprocess.CompletedProcess:
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    out = subprocess.run([*cmd, "--device", rig.device, *args], input=stdin, capture_output=True, text=True,
                         timeout=timeout, cwd=ROOT, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    out.text = out.stdout + out.stderr
    assert "Traceback" not in out.text, out.text
    return out


def test_the_node_is_found_from_the_device_by_its_owner_record(rig):
    owner = find_owner(rig.device)
    assert owner is not None and owner.pid == rig.node_proc.proc.pid and owner.node == "/dynamixel_handler"
    assert owner.domain_id == int(os.environ["ROS_DOMAIN_ID"])


def test_get_and_info_go_through_the_node_with_the_same_output(rig):
    out = tool(rig, "get", "1", "temperature_limit")
    assert out.returncode == 0, out.text
    assert out.stdout.splitlines()[0].startswith(THROUGH)
    limit = rig.sim.servo(1).read("temperature_limit")
    assert f"ID 1 (XM430-W350) temperature_limit = {limit} degC (raw {limit})" in out.stdout
    out = tool(rig, "get", "1,2", "position_p_gain", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 0 and doc["through_node"] == "/dynamixel_handler" and THROUGH in out.stderr
    assert [(s["id"], s["raw"], s["baudrate"]) for s in doc["servos"]] == \
        [(i, rig.sim.servo(i).read("position_p_gain"), 1_000_000) for i in (1, 2)]
    out = tool(rig, "info", "2", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 0 and doc["model"] == "XM430-W350" and doc["torque"] == "on", out.text
    assert doc["items"]["max_position_limit"]["raw"] == rig.sim.servo(2).read("max_position_limit")


def test_set_goes_through_the_node_with_the_tool_s_checks_and_is_read_back_on_the_servo(rig):
    servo = rig.sim.servo(1)
    # a protection lowered: --force; an EEPROM item of a servo holding torque: --torque-off (exit 2, nothing written)
    limit = servo.read("temperature_limit")
    out = tool(rig, "set", "1", "temperature_limit", "90degC", "--yes", "--torque-off")
    assert out.returncode == 2 and "--force" in out.stderr and servo.read("temperature_limit") == limit, out.text
    new = 70 if limit != 70 else 75
    out = tool(rig, "set", "1", "temperature_limit", f"{new}degC", "--yes")
    assert out.returncode == 2 and "give --torque-off" in out.stderr and servo.read("temperature_limit") == limit
    out = tool(rig, "set", "1,2", "temperature_limit", f"{new}degC", "--yes", "--torque-off", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 0 and [s["raw"] for s in doc["servos"]] == [new, new] and THROUGH in out.stderr, out.text
    assert [rig.sim.servo(i).read("temperature_limit") for i in (1, 2)] == [new, new]
    assert servo.read("torque_enable") == 1 and "torque was turned off for the write and back on" in out.stderr
    # a servo the node does not handle: named, the others done
    out = tool(rig, "get", "1,7", "temperature_limit")
    assert out.returncode == 1 and "ID 7: not handled by this node" in out.stderr and "ID 1 (XM430-W350)" in out.stdout


def test_backup_goes_through_the_node_and_holds_the_servos_eeprom_as_they_are(rig, tmp_path):
    import yaml
    out = tool(rig, "backup", str(tmp_path / "b.yaml"), "--servos-block", str(tmp_path / "block.yaml"), "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 0 and doc["ids"] == [1, 2] and doc["through_node"] == "/dynamixel_handler", out.text
    saved = yaml.safe_load((tmp_path / "b.yaml").read_text())["servos"]
    for dxl_id in (1, 2):
        servo = rig.sim.servo(dxl_id)
        assert saved[dxl_id]["baudrate"] == 1_000_000 and saved[dxl_id]["model"] == "XM430-W350"
        for name in ("temperature_limit", "max_position_limit", "shutdown", "drive_mode"):
            assert saved[dxl_id]["eeprom"][name] == servo.read(name), name
    block = yaml.safe_load((tmp_path / "block.yaml").read_text())
    assert "id_1" in json.dumps(block)


def test_monitor_goes_through_the_node(rig):
    out = tool(rig, "monitor", "1,2,9", "--count", "2", "--rate", "20", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 1 and len(doc["refreshes"]) == 2 and doc["missing"] == [9], out.text
    assert "ID 9: not handled by this node" in out.stderr and THROUGH in out.stderr
    last = {s["id"]: s for s in doc["refreshes"][-1]}
    modes = {i: {1: "velocity", 3: "position"}[rig.sim.servo(i).read("operating_mode")] for i in (1, 2)}
    assert sorted(last) == [1, 2] and all(s["reply"] and s["torque"] and s["mode"] == modes[s["id"]] for s in last.values())
    assert abs(last[1]["temp"] - rig.sim.servo(1).read("present_temperature")) <= 1


def test_set_mode_goes_through_the_node_s_own_mode_change_with_the_tool_s_torque_rule(rig):
    servo = rig.sim.servo(2)
    mode = "velocity" if servo.read("operating_mode") != 1 else "position"
    out = tool(rig, "set-mode", "2", mode, "--yes")
    assert out.returncode == 2 and "give --torque-off" in out.stderr, out.text
    out = tool(rig, "set-mode", "2", mode, "--yes", "--torque-off", "--json")
    assert out.returncode == 0 and json.loads(out.stdout)["written"], out.text
    assert servo.read("operating_mode") == {"velocity": 1, "position": 3}[mode] and servo.read("torque_enable") == 1
    assert "torque was turned off for the write and back on" in out.stderr


def test_reboot_goes_through_the_node_with_the_tool_s_torque_rule(rig):
    for dxl_id in (1, 2):
        assert tool(rig, "set", str(dxl_id), "led", "1").returncode == 0
    assert [rig.sim.servo(i).read("led") for i in (1, 2)] == [1, 1]
    out = tool(rig, "reboot", "2", "--yes")  # torque on, no --torque-off: refused, nothing rebooted (exit 2)
    assert out.returncode == 2 and "ID 2: torque is on and a reboot turns it off" in out.stderr, out.text
    assert rig.sim.servo(2).read("led") == 1 and rig.sim.servo(2).read("torque_enable") == 1
    out = tool(rig, "reboot", "2", "--torque-off", "--yes", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 0 and doc["rebooted"] == [2] and doc["through_node"] == "/dynamixel_handler", out.text
    assert "ID 2 (XM430-W350) rebooted and answers again, torque back on (goal := present position)" in out.stderr
    assert rig.sim.servo(2).read("led") == 0 and rig.sim.servo(2).read("torque_enable") == 1  # RAM reset, torque back
    assert rig.sim.servo(1).read("led") == 1  # not named: not rebooted
    # an ID the node does not handle: named, the others rebooted (exit 1)
    out = tool(rig, "reboot", "1,7", "--torque-off", "--yes")
    assert out.returncode == 1 and "ID 7: not handled by this node" in out.stderr, out.text
    assert "ID 1 (XM430-W350) rebooted and answers again" in out.stdout and rig.sim.servo(1).read("led") == 0
    # more IDs than the node handles (the node refuses such a request whole): the one it does not is named
    out = tool(rig, "get", "1,2,7", "led")
    assert out.returncode == 1 and "ID 7: not handled by this node" in out.stderr, out.text
    assert [line for line in out.stdout.splitlines() if " led = " in line] == \
        ["ID 1 (XM430-W350) led = 0", "ID 2 (XM430-W350) led = 0"]


def test_restore_goes_through_the_node_writing_only_what_differs(rig, tmp_path):
    import yaml
    path = tmp_path / "b.yaml"
    assert tool(rig, "backup", str(path)).returncode == 0
    backup = yaml.safe_load(path.read_text())
    one, two = backup["servos"][1]["eeprom"], backup["servos"][2]["eeprom"]
    limit = one["temperature_limit"] - 5
    mode = 1 if two["operating_mode"] != 1 else 3
    one["temperature_limit"], two["operating_mode"] = limit, mode
    path.write_text(yaml.safe_dump(backup))
    out = tool(rig, "restore", str(path), "--dry-run", "--torque-off")
    assert out.returncode == 0 and "2 item(s) would be written" in out.stdout and THROUGH in out.stdout, out.text
    out = tool(rig, "restore", str(path), "--yes")
    assert out.returncode == 2 and "give --torque-off" in out.stderr, out.text
    assert rig.sim.servo(1).read("temperature_limit") == limit + 5
    # the baud rate and a servo the node does not handle: named as not done (exit 1), the rest written
    backup["servos"][2]["eeprom"]["baud_rate"] = 1
    backup["servos"][7] = yaml.safe_load(yaml.safe_dump(backup["servos"][1]))
    path.write_text(yaml.safe_dump(backup))
    out = tool(rig, "restore", str(path), "--yes", "--torque-off", "--json")
    doc = json.loads(out.stdout)
    assert out.returncode == 1 and "ID 7: not handled by this node" in out.stderr, out.text
    assert "baud_rate 57,600 bps (1): it changes the bus under the running node" in out.stderr
    assert [rig.sim.servo(i).read(n) for i, n in ((1, "temperature_limit"), (2, "operating_mode"), (2, "baud_rate"))] \
        == [limit, mode, 3]
    assert [rig.sim.servo(i).read("torque_enable") for i in (1, 2)] == [1, 1]
    assert {s["id"]: len(s["written"]) for s in doc["servos"]} == {1: 1, 2: 1, 7: 0}


def test_a_verb_that_changes_the_bus_is_refused_and_direct_is_refused_as_before(rig):
    out = tool(rig, "set-id", "1", "5", "--yes")
    assert out.returncode == 1 and rig.sim.servo(1).read("id") == 1
    assert len(out.stderr.strip().splitlines()) == 1
    assert "held by the running node /dynamixel_handler" in out.stderr and "changes the bus under it" in out.stderr
    out = tool(rig, "calibrate", "1", "--joints", "j.yaml")
    assert out.returncode == 1 and "calibrate does not go through the node yet" in out.stderr, out.text
    assert "reboot, restore do" in out.stderr
    out = tool(rig, "get", "1", "id", "--direct")
    assert out.returncode == 1 and "is busy" in out.stderr and THROUGH not in out.text


def test_a_get_while_the_adapter_is_gone_is_one_clear_line_within_seconds(rig):
    rig.sim.vanish()
    try:
        start = time.monotonic()
        out = tool(rig, "get", "1", "temperature_limit", timeout=30)
        assert out.returncode == 1 and time.monotonic() - start < 15, out.text
        assert "the bus device is gone" in out.stderr, out.text
    finally:
        rig.sim.reappear()
    rig.wait(lambda: tool(rig, "get", "1", "temperature_limit").returncode == 0, timeout=30, what="the bus back")


def test_a_stale_owner_record_is_ignored(tmp_path):
    from dynamixel_handler.bus import owner_record
    device = tmp_path / "ttyX"
    device.touch()
    env = dict(os.environ, XDG_RUNTIME_DIR=str(tmp_path))
    code = (f"from dynamixel_handler.bus.owner_record import write_record; "
            f"print(write_record({str(device)!r}, '/ns/n', '/ns', 7))")
    subprocess.run([sys.executable, "-c", code], check=True, env=env, cwd=ROOT, capture_output=True)
    os.environ["XDG_RUNTIME_DIR"], old = str(tmp_path), os.environ.get("XDG_RUNTIME_DIR")
    try:
        assert owner_record.find_owner(str(device)) is None  # its process is gone
        paths = owner_record.write_record(str(device), "/ns/n", "/ns", 7)
        assert owner_record.find_owner(str(device)) == owner_record.Owner(os.getpid(), "/ns/n", "/ns", 7)
        owner_record.remove_record(paths)
        assert owner_record.find_owner(str(device)) is None
    finally:
        if old is None:
            del os.environ["XDG_RUNTIME_DIR"]
        else:
            os.environ["XDG_RUNTIME_DIR"] = old


def test_a_record_of_a_device_nobody_holds_is_not_the_node_s(tmp_path, monkeypatch):
    """A node that lost its adapter keeps its record; a tty number given again to another adapter (or
    pseudo-terminal) at the same path is then nobody's: the tool opens it itself, not the node's."""
    import fcntl

    from dynamixel_handler.bus import owner_record
    from dynamixel_handler.setup_tool.through_node import owner_of
    device = tmp_path / "ttyX"
    device.touch()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    paths = owner_record.write_record(str(device), "/ns/n", "/ns", 7)
    try:
        assert owner_record.find_owner(str(device)) is not None  # the record is live (this process)
        assert owner_of(str(device)) is None  # but nobody holds the device
        with open(device, "rb") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as the node's pyserial exclusive open
            assert owner_of(str(device)) == owner_record.Owner(os.getpid(), "/ns/n", "/ns", 7)
        device.unlink()  # unplugged: still the node's (it reconnects)
        assert owner_of(str(device)) == owner_record.Owner(os.getpid(), "/ns/n", "/ns", 7)
    finally:
        owner_record.remove_record(paths)
