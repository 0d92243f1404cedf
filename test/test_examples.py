"""The example controller, run the way the README says: one command starts the virtual bus, the
handler and the example; the simulated servos must really swing (seen in the example's output)."""
from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RUN = ROOT / "examples" / "run_example.sh"
EXAMPLE = ROOT / "examples" / "position_oscillation.py"

needs_ros = pytest.mark.skipif(shutil.which("dynamixel_handler") is None or importlib.util.find_spec("rclpy") is None,
                               reason="needs the ROS environment: source env.sh")


def _env(tmp_path: Path) -> dict[str, str]:
    return dict(os.environ, TMPDIR=str(tmp_path), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")


@needs_ros
def test_run_example_oscillates_the_virtual_servos(tmp_path):
    out = subprocess.run([str(RUN), "--duration", "5"], capture_output=True, text=True, timeout=90,
                         env=_env(tmp_path), start_new_session=True)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text
    swept = {int(i): float(d) for i, d in re.findall(r"ID (\d+): present position swept ([\d.]+) deg", out.stdout)}
    assert set(swept) == {1, 2}, text
    assert all(d > 20.0 for d in swept.values()), text        # ±30° commanded
    assert re.search(r"t=\s*[\d.]+s\s+ID 1: goal\s+-?[\d.]+ present\s+-?[\d.]+", out.stdout), text
    # the node was stopped by the script (it logs its stop sequence) and left nothing behind
    node_log = next(tmp_path.glob("dxl_example.*/node.log")).read_text()
    assert "operating mode -> cur_position" in node_log and "stopping" in node_log


@needs_ros
def test_example_without_a_handler_says_what_is_missing(tmp_path):
    env = _env(tmp_path)
    env["ROS_DOMAIN_ID"] = str(100 + os.getpid() % 100)  # a domain no handler of this run uses
    out = subprocess.run([sys.executable, str(EXAMPLE), "--wait", "1.5"], capture_output=True, text=True,
                         timeout=30, env=env)
    assert out.returncode == 1
    assert "is dynamixel_handler running" in out.stderr
    assert "Traceback" not in out.stderr
