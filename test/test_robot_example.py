"""The example robot: the MoveIt-free script sends a FollowJointTrajectory goal to the handler on
its own virtual bus and saves the plot; the URDF, controllers, handler parameters and launch file
name the same joints and topics."""
from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
ROBOT = ROOT / "examples" / "robot"
SCRIPT = ROOT / "examples" / "follow_trajectory.py"


def test_follow_trajectory_example_succeeds_and_saves_its_plot(tmp_path):
    png = tmp_path / "trajectory.png"
    env = dict(os.environ, TMPDIR=str(tmp_path), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
    out = subprocess.run([sys.executable, str(SCRIPT), "--virtual", "--png", str(png)], capture_output=True,
                         text=True, timeout=120, env=env, cwd=tmp_path)
    text = out.stdout + out.stderr
    named = re.search(r"handler log: (\S+)", out.stdout)  # the example logs to a directory of its own
    log = Path(named.group(1)) if named else tmp_path / "handler.log"
    assert out.returncode == 0, text + (log.read_text() if log.exists() else "")
    assert "result: SUCCESSFUL" in out.stdout
    m = re.search(r"max \|commanded - present\|: ([\d.]+) rad .*median ([\d.]+) rad", out.stdout)
    worst, median = float(m.group(1)), float(m.group(2))
    print(f"\nexample trajectory: |commanded - present| max {worst:.4f} rad, median {median:.4f} rad")
    # the joints follow the path (median); one loop held back on a loaded machine lags the simulated
    # servo for a moment (max), a path followed late or not at all is off everywhere
    assert median < 0.05 and worst < 0.5
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert "stopping" in log.read_text()  # the handler was stopped, servos made safe


def test_the_example_robot_files_name_the_same_joints_and_topics():
    urdf = ET.parse(ROBOT / "pan_tilt.urdf").getroot()
    revolute = [j.get("name") for j in urdf.findall("joint") if j.get("type") == "revolute"]
    control = urdf.find("ros2_control")
    assert control.find("hardware/plugin").text == "joint_state_topic_hardware_interface/JointStateTopicSystem"
    hw = {p.get("name"): p.text for p in control.findall("hardware/param")}
    controlled = [j.get("name") for j in control.findall("joint")]
    assert controlled == revolute == ["pan", "tilt"]
    handler = yaml.safe_load((ROBOT / "handler.yaml").read_text())["/**"]["ros__parameters"]
    assert handler["joint_state"]["names"] == controlled and handler["joint_state"]["use"] is True
    controllers = yaml.safe_load((ROBOT / "controllers.yaml").read_text())
    assert controllers["joint_trajectory_controller"]["ros__parameters"]["joints"] == controlled
    assert controllers["forward_position_controller"]["ros__parameters"]["joints"] == controlled
    # the launch file remaps the handler's topics onto the ones the URDF's hardware interface uses
    launch = (ROBOT / "pan_tilt_launch.py").read_text()
    ast.parse(launch)
    remaps = dict(re.findall(r'\("(joint_\w+)", "(/[\w/]+)"\)', launch))
    assert remaps == {"joint_states": hw["joint_states_topic"], "joint_commands": hw["joint_commands_topic"]}
