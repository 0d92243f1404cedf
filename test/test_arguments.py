"""Command-line arguments: a -p override always takes effect, even where ROS would lose it (several
params files, as scripts/run.sh passes them; a type that differs from the file's), or start-up
stops with one line saying which one and why; a missing or malformed params file, or `-p name:=`
without a value, is one FATAL line naming the file and the line, exit code 2."""
from __future__ import annotations

from pathlib import Path

from dynamixel_handler.sim import VirtualBus

from support.ros import CONFIG, ROOT, NodeProcess, node_command

X = 1020
VIRTUAL_BUS = ROOT / "config" / "config_virtual_bus.yaml"


def _as_run_sh(*params: str) -> list[str]:
    """The node's command line as scripts/run.sh builds it: both params files, then the -p's."""
    cmd = node_command(*params)
    k = cmd.index("--params-file") + 2
    return cmd[:k] + ["--params-file", str(VIRTUAL_BUS)] + cmd[k:]


def _fatal_only(proc: NodeProcess) -> str:
    assert "Traceback" not in proc.output, proc.output
    assert "[rcl]" not in proc.output, proc.output  # rcl's own "Failed to parse" line is not reached
    fatal = [line for line in proc.lines if line.startswith("[FATAL]")]
    assert len(fatal) == 1, proc.output
    return fatal[0]


def test_overrides_win_over_several_params_files():
    sim = VirtualBus(servos={i: X for i in range(1, 5)}, wire_timing=False)
    try:
        proc = NodeProcess(_as_run_sh(f"device_name:={sim.start()}", "init/servo_auto_search.max_id:=3",
                                      "init/expected_servo_num:=3", "loop_rate:=50.0", "verbose_ratio:=0"))
        proc.wait_for("handled", timeout=30)
        proc.wait_for("ID 3: XM430-W350")
        code = proc.stop()
    finally:
        sim.stop()
    assert code == 0, proc.output
    assert "of IDs 1..3" in proc.output and "ID 4:" not in proc.output, proc.output
    assert "loop_rate=50," in proc.output, proc.output
    assert "parameter 'init/servo_auto_search.max_id': the command-line value 3 applied" in proc.output


def test_an_override_that_cannot_be_applied_stops_start_up_with_one_line():
    proc = NodeProcess(_as_run_sh("device_name:=/dev/null", "baudrate:=fast"))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    line = _fatal_only(proc)
    assert "-p baudrate:=fast cannot be applied" in line and "must be int" in line, line


def test_a_missing_params_file_is_one_fatal_line(tmp_path: Path):
    missing = tmp_path / "nowhere.yaml"
    proc = NodeProcess(node_command("device_name:=/dev/null", params_file=missing))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    line = _fatal_only(proc)
    assert str(missing) in line and "No such file" in line, line


def test_a_params_file_deep_in_a_workspace_is_named_whole(tmp_path: Path):
    """A path cut short names no file: one as long as an install tree's (here 150+ characters)
    is named whole in the line."""
    missing = tmp_path / "ros2_ws" / "install" / ("my_robot_bringup_" * 3) / "share" / "config" / "dynamixel.yaml"
    assert len(str(missing)) > 150
    proc = NodeProcess(node_command("device_name:=/dev/null", params_file=missing))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    line = _fatal_only(proc)
    assert f"params file {missing}: cannot read it" in line, line


def test_a_malformed_params_file_is_one_fatal_line_naming_the_yaml_line(tmp_path: Path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("dynamixel_handler:\n  ros__parameters:\n    loop_rate: [1, 2\n    baudrate: 57600\n")
    proc = NodeProcess(node_command("device_name:=/dev/null", params_file=bad))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    line = _fatal_only(proc)
    assert str(bad) in line and "line 4" in line, line


def test_an_override_without_a_value_is_one_fatal_line():
    proc = NodeProcess(node_command("device_name:=", params_file=CONFIG))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    line = _fatal_only(proc)
    assert "device_name:=" in line and "no value" in line, line


def _started(*params: str, params_files: tuple[Path, ...] = ()) -> str:
    """The node's log from start until its servo is handled, then stopped."""
    sim = VirtualBus(servos={1: X}, wire_timing=False)
    try:
        cmd = node_command(f"device_name:={sim.start()}", "init/servo_auto_search.max_id:=1",
                           "init/expected_servo_num:=1", *params)
        k = cmd.index("--params-file") + 2
        for path in params_files:
            cmd[k:k] = ["--params-file", str(path)]
        proc = NodeProcess(cmd)
        proc.wait_for("handled", timeout=30)
        assert proc.stop() == 0, proc.output
    finally:
        sim.stop()
    return proc.output


def test_a_params_file_that_sets_nothing_is_one_warning_naming_it(tmp_path: Path):
    empty, scalar, other = tmp_path / "empty.yaml", tmp_path / "scalar.yaml", tmp_path / "other.yaml"
    empty.write_text("# nothing here yet\n")
    scalar.write_text("loop_rate\n")
    other.write_text("dynamixel_handler:\n  ros__parameters: {}\n")
    out = _started(params_files=(empty, scalar, other))
    warnings = [line for line in out.splitlines() if "sets nothing" in line]
    assert len(warnings) == 3, out
    assert all(line.startswith("[WARN]") for line in warnings), warnings
    assert any(str(empty) in w and "it is empty" in w for w in warnings), warnings
    assert any(str(scalar) in w and "YAML scalar" in w for w in warnings), warnings
    assert any(str(other) in w and "ros__parameters" in w for w in warnings), warnings
    assert "sets nothing" not in _started()  # the shipped file sets parameters: no such line


def test_the_start_up_line_counts_command_line_values_as_set_not_as_defaults():
    out = _started("latency_timer:=1", "init/used_servo_series.P:=true")
    line = next(line for line in out.splitlines() if "parameters at their defaults" in line)
    # device_name and latency_timer are on the first line; of the others, two are set here
    # (P series, max_id) and expected_servo_num: three, and the count of the rest excludes all of them
    from dynamixel_handler.config import SCHEMA
    others = len(SCHEMA) - 4  # device_name, baudrate, latency_timer, loop_rate are listed on their own
    assert f"{others - 3} other parameters at their defaults, 3 set:" in line, line
