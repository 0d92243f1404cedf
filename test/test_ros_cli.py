"""scripts/ros_cli.py, the stand-in for `ros2 topic` / `ros2 param` that docs/ros2_cli.md uses where
the ros2 command line is not installed, against the real node; and a clamp warning as the log
shows it (the servo and the field)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from dynamixel_handler_msgs.msg import DynamixelControlXPosition

from support.rig import Rig, X

CLI = [sys.executable, str(Path(__file__).resolve().parent.parent / "scripts" / "ros_cli.py")]


def _cli(*args: str) -> str:
    out = subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout


def test_ros_cli_stand_ins_read_and_command_the_node():
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
