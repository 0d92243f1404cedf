"""The port lock the handler and the set-up tool share, the tool's installed entry points, and its
value parsing (names, units, the model's ranges) against the real control tables."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_prefix

from dynamixel_handler.bus import BusError, DynamixelBus
from dynamixel_handler.bus.lock_holder import lock_holder
from dynamixel_handler.bus.ops import Ping
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.setup_tool.errors import BadArguments
from dynamixel_handler.setup_tool.items import find_item, parse_value, show_value
from dynamixel_handler.sim import VirtualBus

ROOT = Path(__file__).resolve().parent.parent
XM430, PH54, XL330 = 1020, 2020, 1200


def test_an_open_bus_holds_the_device_lock_and_a_second_opener_is_told_who():
    with VirtualBus({1: XM430}, wire_timing=False) as sim:
        assert lock_holder(sim.path) is None
        with DynamixelBus(sim.path, 57600, latency_timer_ms=1.0):
            pid, _program = lock_holder(sim.path)
            assert pid == os.getpid()
            with pytest.raises(BusError, match=rf"is busy: .* \(pid {os.getpid()}\) holds it\. Stop it first"):
                DynamixelBus(sim.path, 57600).open()
            out = subprocess.run([sys.executable, "-m", "dynamixel_handler.setup_tool", "--device", sim.path,
                                  "get", "1", "id"], capture_output=True, text=True, timeout=30, cwd=ROOT)
            assert out.returncode == 1
            assert out.stderr.strip().splitlines() == [out.stderr.strip()]
            assert f"is busy: {_program} (pid {os.getpid()}) holds it" in out.stderr and f"kill {os.getpid()}" in out.stderr
        assert lock_holder(sim.path) is None  # closed: the lock went with it
        with DynamixelBus(sim.path, 57600, latency_timer_ms=1.0) as bus:
            assert bus.execute(Ping(1, protocol=2)).value == XM430


def test_ros2_run_finds_the_setup_executable_and_the_console_script_runs():
    prefix = get_package_prefix("dynamixel_handler")
    for name in ("setup", "dynamixel_handler_setup"):  # `ros2 run dynamixel_handler setup` runs lib/<package>/setup
        exe = Path(prefix) / "lib" / "dynamixel_handler" / name
        assert exe.is_file() and os.access(exe, os.X_OK), exe
        out = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=30)
        assert out.returncode == 0 and "assign-ids" in out.stdout and "factory-reset" in out.stdout


def test_no_rclpy_is_imported_by_the_tool():
    code = ("import sys; from dynamixel_handler.setup_tool import cli; cli.build_parser(); "
            "print(any(m.startswith('rclpy') for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30, cwd=ROOT)
    assert out.stdout.strip() == "False", out.stderr


@pytest.mark.parametrize("model, item, text, raw", [
    (XM430, "max_position_limit", "170deg", 2048 + 1934),     # 360/4096 deg per pulse around 2048
    (XM430, "max_position_limit", "1.5rad", 2048 + 978),     # 85.94 deg
    (XM430, "max_position_limit", "3000", 3000),              # a whole number with --raw is the raw value
    (XM430, "current_limit", "300mA", 112),                   # 2.69 mA per pulse
    (XM430, "current_limit", "0.3A", 112),
    (XM430, "max_voltage_limit", "12.0V", 120),               # 0.1 V per pulse
    (XM430, "velocity_limit", "60rpm", 262),                  # 0.229 rpm per pulse
    (XM430, "return_delay_time", "20us", 10),                 # 2 us per pulse
    (XM430, "temperature_limit", "70degC", 70),
    (PH54, "min_position_limit", "-90deg", -250961),          # PH54-200: 501,923 pulses per half turn
    (XL330, "Max-Position-Limit", "90deg", 2048 + 1024),
])
def test_values_in_units_become_raw_register_values(model, item, text, raw):
    m = model_by_number(model)
    got = parse_value(m, find_item(m, item), text, "ID 1", raw=text.isdigit())
    if model == PH54:
        assert got == pytest.approx(raw, abs=2)
    else:
        assert got == raw


@pytest.mark.parametrize("item, text, why", [
    ("max_position_limit", "400deg", "out of range for XM430-W350"),
    ("id", "253", "out of range"),
    ("baud_rate", "12", "is not one XM430-W350 takes"),
    ("operating_mode", "2", "is not one XM430-W350 takes"),
    ("current_limit", "3V", "current_limit is in mA, not 'V'"),
    ("drive_mode", "1deg", "has no physical unit"),
    ("current_limit", "1.5", r"takes a whole raw value or a value with its unit \(mA\)"),
    ("current_limit", "lots", "is not a value for current_limit"),
    ("max_position_limit", "90", r"90 = 90 deg\? write 90deg, or --raw for register value 90"),  # no unit, no --raw
    ("max_position_limit", "1e400deg", "is not a finite number"),
])
def test_values_the_model_does_not_take_are_refused_with_one_line(item, text, why):
    m = model_by_number(XM430)
    with pytest.raises(BadArguments, match=why) as err:
        parse_value(m, find_item(m, item), text, "ID 1 (XM430-W350)")
    assert "\n" not in str(err.value) and str(err.value).startswith("ID 1 (XM430-W350): ")


def test_item_names_and_shown_values():
    m = model_by_number(XM430)
    with pytest.raises(BadArguments, match=r"has no control-table item 'position_limit' \(did you mean max_position_limit"):
        find_item(m, "position_limit")
    assert show_value(m, find_item(m, "max_voltage_limit"), 160) == "16 V (raw 160)"
    assert show_value(m, find_item(m, "operating_mode"), 3) == "position (3)"
    assert show_value(m, find_item(m, "drive_mode"), 4) == "4"


def test_the_device_is_found_by_its_usb_serial_number_as_the_handler_finds_it(tmp_path):
    links = tmp_path / "by-id"
    links.mkdir()
    with VirtualBus({3: XM430}, wire_timing=False) as sim:
        (links / "usb-FTDI_USB__-__Serial_Converter_FT4TFSJ1-if00-port0").symlink_to(sim.path)
        env = dict(os.environ, DYNAMIXEL_HANDLER_SERIAL_BY_ID_DIR=str(links))
        cmd = [sys.executable, "-m", "dynamixel_handler.setup_tool", "--device", "serial:FT4TFSJ1", "get", "3", "id"]
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=30, cwd=ROOT, env=env)
        assert out.returncode == 0 and "ID 3 (XM430-W350) id = 3" in out.stdout, out.stdout + out.stderr
        cmd[cmd.index("serial:FT4TFSJ1")] = "serial:NOSUCH1"
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=30, cwd=ROOT, env=env)
        assert out.returncode == 1 and "no adapter with USB serial number NOSUCH1; adapters seen: FT4TFSJ1" in out.stderr
