"""scripts/ros_cli.py, the stand-in for `ros2 topic` / `ros2 param` that docs/ros2_cli.md uses where
the ros2 command line is not installed, against the real node; and a clamp warning as the log
shows it (the servo and the field)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DynamixelControlXPosition

from support.rig import Rig, X
from support.ros import CONFIG, PATIENT_SCAN, NodeProcess

CLI = [sys.executable, str(Path(__file__).resolve().parent.parent / "scripts" / "ros_cli.py")]


def _cli(*args: str) -> str:
    out = subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout


def test_ros_cli_stand_ins_read_command_call_and_describe_the_node():
    rig = Rig({1: X, 2: X})
    try:
        assert _cli("param", "get", "/dynamixel_handler", "loop_rate") == "Integer value is: 100\n"
        echoed = _cli("topic", "echo", "/dynamixel/debug", "--once")
        assert "id_list: [1, 2]" in echoed and echoed.rstrip().endswith("---")
        # `topic pub` leaves only once the node's subscription has acknowledged the message: the
        # node's side of the match can come after the publisher's (on a loaded machine by more than
        # the 0.2 s the stand-in used to wait), and a message sent before it is dropped unless
        # the publisher is still there to send it again. One publish is enough.
        _cli("topic", "pub", "/dynamixel/shortcut", "dynamixel_handler_msgs/msg/DynamixelShortcut",
             "{command: 'TOFF', id_list: [2]}")
        rig.wait(lambda: rig.sim.servo(2).read("torque_enable") == 0, timeout=5, what="torque off on ID 2")
        # the window includes the subscriber's discovery, which a loaded machine makes longer
        assert "average rate" in _cli("topic", "hz", "/dynamixel/states", "--seconds", "3")
        # services, actions and parameter descriptions
        services = _cli("service", "list", "--seconds", "3").split()
        for name in ("/dynamixel/set_torque", "/dynamixel/move_to", "/dynamixel/reboot",
                     "/dynamixel/save_servo_settings", "/dynamixel/set_e_stop", "/dynamixel_handler/describe_parameters"):
            assert name in services, services
        answer = _cli("service", "call", "/dynamixel/set_torque", "dynamixel_handler_msgs/srv/SetTorque",
                      "{ids: [1], enable: true}")
        assert "response:" in answer and "success=True" in answer, answer
        rig.wait(lambda: rig.sim.servo(1).read("torque_enable") == 1, timeout=10, what="torque on at ID 1")
        here = rig.sim.servo(1)
        start = (here.read("present_position") - here.model.position_zero_pulse) * here.model.position_deg_per_pulse
        target = 20.0 if start < 0 else -20.0  # within the servo's limits from wherever it is
        result = _cli("action", "send_goal", "/dynamixel/move_joints", "dynamixel_handler_msgs/action/MoveJoints",
                      f"{{ids: [1], positions_deg: [{target}], timeout_s: 20.0}}", "--feedback")
        assert "Goal accepted with ID:" in result and "Goal finished with status: SUCCEEDED" in result, result
        described = _cli("param", "describe", "/dynamixel_handler", "loop_rate")
        assert "Parameter name: loop_rate" in described and "Type: integer" in described, described
        assert "Read only: true" in described, described  # read at start-up only: a set would be refused
        refused = _cli("param", "set", "/dynamixel_handler", "loop_rate", "50")
        assert refused.startswith("Setting parameter failed"), refused
    finally:
        rig.close()


def test_a_clamp_warning_names_the_servo_and_the_field():
    rig = Rig({1: X})
    try:
        mark = rig.mark()
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1], position_deg=[200.0]))
        line = rig.wait_log("clamped", since=mark)
        assert "ID 1 (XM430-W350) 'position_deg' = 200" in line, line
        assert "command/" not in line, line
    finally:
        rig.close()


def test_ros_cli_stand_in_drives_the_lifecycle_node():
    sim = VirtualBus(servos={1: X, 2: X}, wire_timing=False)
    device = sim.start()
    exe = ([sys.executable, "-m", "dynamixel_handler.ros.lifecycle_node"] if os.environ.get("DXL_TEST_MODULE")
           else ["dynamixel_handler_lifecycle"])
    params = [f"device_name:={device}", "init/servo_auto_search.min_id:=1", "init/servo_auto_search.max_id:=2",
              "init/expected_servo_num:=2", PATIENT_SCAN, "verbose_ratio:=0"]
    node = NodeProcess(exe + ["--ros-args", "--params-file", str(CONFIG)] + [a for p in params for a in ("-p", p)])
    try:
        node.wait_for("waiting for the configure transition", timeout=30)
        assert _cli("lifecycle", "get", "/dynamixel_handler") == "unconfigured [1]\n"
        assert _cli("lifecycle", "set", "/dynamixel_handler", "configure") == "Transitioning successful\n"
        assert _cli("lifecycle", "get", "/dynamixel_handler") == "inactive [2]\n"
        out = subprocess.run(CLI + ["lifecycle", "set", "/dynamixel_handler", "fly"], capture_output=True, text=True,
                             timeout=60)
        assert out.returncode != 0 and "unknown transition 'fly'" in out.stderr
    finally:
        assert node.stop() == 0
        sim.close()
