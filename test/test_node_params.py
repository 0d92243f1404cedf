"""The node's parameter surface: the shipped YAML starts it, bad values stop it with one clear line."""
from __future__ import annotations

import signal
import textwrap

import yaml

from dynamixel_handler.config import SCHEMA

from support.ros import CONFIG, NodeProcess, node_command


def _flatten(tree: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in tree.items():
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            out.update(_flatten(value, name))
        else:
            out[name] = value
    return out


def _write(tmp_path, body: str):
    path = tmp_path / "params.yaml"
    path.write_text("/**:\n  ros__parameters:\n" + textwrap.indent(textwrap.dedent(body), "    "))
    return path


def test_shipped_yaml_holds_every_parameter_with_its_default():
    flat = _flatten(yaml.safe_load(CONFIG.read_text())["/**"]["ros__parameters"])
    assert flat == {p.name: p.default for p in SCHEMA}


def test_node_starts_with_the_shipped_yaml_reports_parameters_and_exits_0_on_sigint():
    node = NodeProcess(node_command("debug:=true", "loop_rate:=50"))
    try:
        line = node.wait_for("loop_rate=50", timeout=30)
        assert "device_name=/dev/ttyUSB0" in line and "baudrate=57600" in line
        node.wait_for("debug:")  # the non-default parameter is listed with its default
    finally:
        code = node.stop(signal.SIGINT)
    assert code == 0, node.output
    assert "Traceback" not in node.output


def test_ill_typed_value_stops_start_up_with_one_clear_line(tmp_path):
    node = NodeProcess(node_command(params_file=_write(tmp_path, "baudrate: fast\ndebug: true\n")))
    assert node.wait_exit() != 0
    assert "parameter 'baudrate' must be int, got 'fast'" in node.output
    assert "Traceback" not in node.output


def test_out_of_range_values_stop_start_up(tmp_path):
    for body, needle in [
        ("loop_rate: -5\n", "'loop_rate' = -5"),
        ("init/servo_auto_search: {min_id: 9, max_id: 3}\n", "max_id' (3) is below min_id (9)"),
        ("baudrate: 12345\n", "not a Dynamixel baud rate"),
        ("pub_ratio/present: {current: -1}\n", "'pub_ratio/present.current' = -1 must be >= 0"),
        ("init/used_servo_series: {X: false, P: false, Pro: false}\n", "enable at least one series"),
    ]:
        node = NodeProcess(node_command(params_file=_write(tmp_path, body + "debug: true\n")))
        assert node.wait_exit() == 2, node.output
        assert needle in node.output
        assert "Traceback" not in node.output


def test_unknown_parameter_gets_an_error_line_with_a_suggestion_and_is_ignored(tmp_path):
    params = _write(tmp_path, "loop_rat: 30\ndebug: true\noption/imu_opencr: {use: false, gyro_range: 3}\n")
    node = NodeProcess(node_command(params_file=params))
    try:
        node.wait_for("unknown parameter 'loop_rat' ignored: did you mean 'loop_rate'?", timeout=30)
        node.wait_for("loop_rate=100")
    finally:
        assert node.stop() == 0
    assert "gyro_range" not in node.output  # extra keys of the original handler's IMU option load silently


def test_integers_load_into_float_parameters_and_integral_floats_into_integers(tmp_path):
    params = _write(tmp_path, "default/profile_vel: 500\nloop_rate: 40.0\ndebug: true\n")
    node = NodeProcess(node_command(params_file=params))
    try:
        node.wait_for("loop_rate=40", timeout=30)
        node.wait_for("default/profile_vel: 500.0")
    finally:
        assert node.stop() == 0
