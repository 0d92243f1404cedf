"""A robot that ran the original handler switches without edits: its YAML files load without one
"unknown parameter" line (their older spellings are read as the parameter they name), and the
extra fields behave as there: LED thresholds and rounding, the PWM slope of the X330, the Pro's
protocol type, a default profile a servo refuses is logged."""
from __future__ import annotations

from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node
from rclpy.parameter_client import AsyncParameterClient

from dynamixel_handler.protocol import ERR_DATA_LIMIT
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DynamixelExtra

from support.rig import PRO, P, Rig, X
from support.ros import PATIENT_SCAN, NodeProcess, node_command, spin_until

DATA = Path(__file__).resolve().parent / "data"
XL330 = 1200  # XL330-M288: the X with a PWM slope register


def _parameters(node_name: str, names: list[str]) -> dict:
    """The node's parameter values as `ros2 param get` reads them (its parameter services)."""
    from rclpy.executors import SingleThreadedExecutor
    rclpy.init()
    try:
        node = Node("param_reader")
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        client = AsyncParameterClient(node, node_name)
        assert spin_until(node, executor, lambda: client.services_are_ready(), timeout=20)
        future = client.get_parameters(names)
        assert spin_until(node, executor, future.done, timeout=10)
        from rclpy.parameter import parameter_value_to_python
        return {n: (list(v) if isinstance(v := parameter_value_to_python(value), (list, tuple)) else v)
                for n, value in zip(names, future.result().values)}
    finally:
        rclpy.try_shutdown()


@pytest.mark.parametrize("name,expected", [
    ("original_config_dynamixel_handler.yaml",
     {"pub_ratio/extra.static_items": 407, "verbose/write_extra": False, "verbose/read_extra.raw": False}),
    ("original_config_dynamixel_handler-fast.yaml",
     {"pub_ratio/extra.static_items": 90130, "pub_ratio/extra.dynamic_items": 90130,
      "init/dummy_servo_list": [2, 3, 7, 9], "verbose/read_status.raw": False}),
    # ours under the same name, shipped in config/
    ("../../config/config_dynamixel_handler-fast.yaml", {"method/fast_read": True, "pub_ratio/extra.static_items": 90130}),
])
def test_original_handler_yaml_loads_without_unknown_parameter_lines(name, expected):
    with VirtualBus({1: X}) as sim:
        # the device, its baud rate and the scan are this bus's; everything else is the file's
        cmd = node_command(f"device_name:={sim.path}", "baudrate:=57600", "latency_timer:=1",
                           "init/baudrate_auto_set:=false", "init/servo_auto_search.max_id:=1",
                           PATIENT_SCAN,  # a busy host: scan until one answers
                           "verbose_ratio:=0", "loop_rate:=100", params_file=DATA / name)
        proc = NodeProcess(cmd)
        try:
            proc.wait_for("handled", timeout=30)
            values = _parameters("/dynamixel_handler", list(expected))
        finally:
            code = proc.stop()
        assert code == 0, proc.output
        assert "unknown parameter" not in proc.output, proc.output
        assert values == expected


# ---------------------------------------------------------------------- extra fields
def _reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def _wait_reg(rig: Rig, dxl_id: int, item: str, value: int) -> None:
    rig.wait(lambda: _reg(rig, dxl_id, item) == value, timeout=10,
             what=f"ID {dxl_id} {item} == {value} (holds {_reg(rig, dxl_id, item)})")


def _led(rig: Rig, red: list[float]) -> None:
    msg = DynamixelExtra(id_list=[1, 2])
    msg.led.red_percent = red
    rig.publish("/dynamixel/command/extra", msg)


def test_led_thresholds_and_rounding_as_the_original_handler():
    rig = Rig({1: X, 2: P})
    try:
        _led(rig, [50.0, 50.0])  # X: on from 50 %; P: 50 % is 128 of 255 (half up)
        _wait_reg(rig, 2, "led_red", 128)
        assert _reg(rig, 1, "led") == 1
        _led(rig, [49.9, 30.0])  # X: off below 50 %; P: 30 % is 76.5 -> 77
        _wait_reg(rig, 2, "led_red", 77)
        assert _reg(rig, 1, "led") == 0
    finally:
        rig.close()


def test_pwm_slope_is_written_on_an_x330_and_refused_elsewhere():
    rig = Rig({1: XL330, 2: X})
    try:
        mark = rig.mark()
        rig.publish("/dynamixel/command/extra", DynamixelExtra(id_list=[1, 2], pwm_slope_percent=[200.0, 200.0]))
        _wait_reg(rig, 1, "pwm_slope", 200)
        rig.wait_log("ID 2", "no pwm_slope", since=mark)
        assert "read-only" not in rig.log_since(mark)
        mark = rig.mark()
        rig.publish("/dynamixel/command/extra", DynamixelExtra(id_list=[1], pwm_slope_percent=[0.0]))
        rig.wait_log("ID 1", "pwm_slope_percent", "out of range", since=mark)
        assert _reg(rig, 1, "pwm_slope") == 200
    finally:
        rig.close()


def test_pro_protocol_type_is_2():
    rig = Rig({1: PRO, 2: X}, "pub_ratio/extra.static_items:=3", "pub_ratio/extra.dynamic_items:=3")
    try:
        rig.wait(lambda: rig.state_of("extra", "protocol_type", 1) is not None, timeout=10, what="an extra state")
        assert rig.state_of("extra", "protocol_type", 1) == 2
        assert rig.state_of("extra", "protocol_type", 2) == _reg(rig, 2, "protocol_type") == 2
    finally:
        rig.close()


def _refuse_profiles_above_limits(sim: VirtualBus) -> None:
    """The P firmware's range of Profile Velocity / Acceleration (e-Manual: 0 .. Velocity /
    Acceleration Limit), which the virtual P servo does not check by itself."""
    servo = sim.servo(2)
    check = servo.check_write

    def with_profile_limits(address: int, data: bytes):
        error, changes = check(address, data)
        for item, value in changes:
            limit = {"profile_velocity": "velocity_limit", "profile_acceleration": "acceleration_limit"}.get(item.name)
            if not error and limit is not None and value > servo.read(limit):
                return ERR_DATA_LIMIT, []
        return error, changes
    servo.check_write = with_profile_limits  # type: ignore[method-assign]


def test_a_default_profile_beyond_the_servo_s_limit_is_lowered_to_it_with_one_line():
    # 1000 deg/s is far above a PH54-200's velocity limit (~174 deg/s): the servo would refuse it
    rig = Rig({1: X, 2: P}, before_start=_refuse_profiles_above_limits)
    try:
        line = rig.wait_log("ID 2", "default/profile_vel", "beyond what it takes")
        assert "profile_velocity set to 174" in line, line
        assert rig.sim.servo(2).read("profile_velocity") == rig.sim.servo(2).read("velocity_limit")
        assert not [ln for ln in rig.node_proc.lines if "ID 1 " in ln and ("not set" in ln or "beyond" in ln)]
        assert list(rig.sim.refused) == []
    finally:
        rig.close()


def test_a_command_line_override_ros_drops_for_its_type_is_applied_or_stops_start_up():
    """ROS drops, without a word, a `-p` whose type differs from the params file's value (`-p
    loop_rate:=50.0` against the file's `loop_rate: 100`). The node applies it in the parameter's
    type, or stops with one line when it cannot (`-p loop_rate:=50.5`: not an integer)."""
    proc = NodeProcess(node_command("device_name:=/dev/null", "loop_rate:=50.0"))
    assert proc.wait_exit(timeout=30) == 1, proc.output  # the run ends at the device, not a tty
    assert "loop_rate=50," in proc.output and "the command-line value 50.0 applied" in proc.output, proc.output
    proc = NodeProcess(node_command("device_name:=/dev/null", "loop_rate:=50.5"))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    fatal = [ln for ln in proc.lines if ln.startswith("[FATAL]")]
    assert len(fatal) == 1 and "-p loop_rate:=50.5 cannot be applied" in fatal[0], proc.output
