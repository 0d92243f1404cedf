"""The handler's loop without ROS (``dynamixel_handler/loop/runner.py``), shown by the example script
``examples/plain_python.py`` run as a user would, against a virtual bus served by this test: the
servos must really move to the goal (their registers in the simulator), the loop's states must
reach the script, and rclpy must never be imported."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from dynamixel_handler.sim import VirtualBus

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "plain_python.py"
XM430 = 1020
#: X series: 4096 pulses a turn, 0° at 2048
X_ZERO, X_DEG = 2048, 360 / 4096


def _run(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
    return subprocess.run([sys.executable, str(EXAMPLE), *args], capture_output=True, text=True, timeout=120,
                          env=env, cwd=ROOT)


def test_plain_python_drives_the_servos_to_a_goal_without_rclpy():
    sim = VirtualBus(servos={1: XM430, 2: XM430}, baudrate=1_000_000)
    path = sim.start()
    try:
        before = [sim.servo(i).read("present_position") for i in (1, 2)]
        out = _run("--device", path, "--baudrate", "1000000", "--ids", "1,2", "--goal", "45",
                   "--loops", "200", "--rate", "100", "--print-every", "20")
        assert out.returncode == 0, out.stdout + out.stderr
        # the goal really reached the servos: the simulated registers, not what the script says
        goal = X_ZERO + round(45 / X_DEG)
        for i in (1, 2):
            present = sim.servo(i).read("present_position")
            assert abs(present - goal) <= 5, (i, before, present, out.stdout)
    finally:
        sim.close()
    # the loop handed its states over: position lines from the loop thread, the last one at the goal
    lines = re.findall(r"^loop (\d+): 1=(-?\d+\.\d) 2=(-?\d+\.\d)$", out.stdout, re.M)
    assert len(lines) >= 3, out.stdout
    final = re.search(r"^final: 1=(-?\d+\.\d) 2=(-?\d+\.\d)$", out.stdout, re.M)
    assert final is not None and all(abs(float(v) - 45) < 0.5 for v in final.groups()), out.stdout
    assert "rclpy imported: False" in out.stdout, out.stdout


def test_plain_python_runs_its_own_virtual_bus():
    out = _run("--loops", "60", "--goal", "-20", "--print-every", "10")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "virtual bus on /dev/" in out.stdout
    assert "scan" in out.stderr and "2 servo(s) [1, 2]" in out.stderr, out.stderr
    assert re.search(r"^loop \d+: 1=", out.stdout, re.M), out.stdout
    assert "rclpy imported: False" in out.stdout, out.stdout


def test_plain_python_takes_per_servo_settings_as_typed_values():
    sim = VirtualBus(servos={1: XM430, 2: XM430}, baudrate=1_000_000)
    path = sim.start()
    try:
        out = _run("--device", path, "--baudrate", "1000000", "--ids", "1,2", "--loops", "50", "--p-gain", "640",
                   "--profile-vel", "60")
        assert out.returncode == 0, out.stdout + out.stderr
        for i in (1, 2):  # on the servos, not what the script says
            assert sim.servo(i).read("position_p_gain") == 640
            assert sim.servo(i).read("profile_velocity") == round(60 / (0.229 * 6))
    finally:
        sim.close()
    assert "ID 1 (XM430-W350): servos.id_1 set: position_p_gain_pulse 640, profile_vel_deg_s 60.0; read back" in out.stderr
    assert "rclpy imported: False" in out.stdout, out.stdout
