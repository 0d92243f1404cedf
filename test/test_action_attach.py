"""The follow_joint_trajectory action is attached by the node after looking for control_msgs
itself: a missing package gives one info line (test_control_msgs.py), while an error in our own
action module stops the node with that error, never reads as "control_msgs is not available"."""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

needs_ros = pytest.mark.skipif(importlib.util.find_spec("rclpy") is None or shutil.which("dynamixel_handler") is None,
                               reason="needs the ROS environment: source env.sh")


@needs_ros
def test_missing_package_looks_only_for_the_package():
    from dynamixel_handler.ros.joint_commands import missing_package
    assert importlib.util.find_spec("control_msgs") is not None  # the development control_msgs
    assert missing_package("control_msgs") is None
    assert missing_package("control_msgs_not_here") == "No module named 'control_msgs_not_here'"


#: the real node's main, with our action module made to fail on import (a test-only finder)
_BROKEN_ACTION = textwrap.dedent("""\
    import sys
    class Broken:
        def find_spec(self, name, path=None, target=None):
            if name == "dynamixel_handler.ros.trajectory_action":
                raise ImportError("broken on purpose by the test")
            return None
    sys.meta_path.insert(0, Broken())
    from dynamixel_handler.ros.node import main
    sys.exit(main())
    """)


@needs_ros
def test_an_error_in_our_action_module_is_not_reported_as_control_msgs_missing(tmp_path):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_LOG_DIR=str(tmp_path),
               ROS_DOMAIN_ID=str(100 + os.getpid() % 100))
    args = ["--ros-args", "-p", "debug:=true", "-p", f"device_name:={tmp_path / 'no_device'}",
            "-p", "joint_state.use:=true", "-p", "joint_state.names:=[pan]", "-p", "joint_state.ids:=[1]"]
    out = subprocess.run([sys.executable, "-c", _BROKEN_ACTION, *args], capture_output=True, text=True,
                         timeout=120, env=env)
    text = out.stdout + out.stderr
    assert out.returncode == 1, text  # a start-up failure, not a node running without its action
    assert "broken on purpose by the test" in text, text
    assert "control_msgs is not available" not in text, text
