"""The node leaves the ROS environment as the user set it: on a robot its DDS discovery range,
domain and middleware are the robot's, never narrowed to this machine by the node itself.

The node runs here without ROS_AUTOMATIC_DISCOVERY_RANGE set, so it discovers as a robot's node
would; to keep that discovery traffic on this machine it runs in a network namespace of its own
that has nothing but a loopback interface."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from dynamixel_handler.sim import VirtualBus

from support.ros import CONFIG, PATIENT_SCAN, NodeProcess

X = 1020

# Runs the installed node's entry point like its console script does, then prints what of its
# own environment differs from what it inherited.
WRAPPER = """
import json, os, sys
from dynamixel_handler.ros.node import main
before = dict(os.environ)
try:
    code = main(sys.argv[1:])
finally:
    after = dict(os.environ)
    changed = {k: [before.get(k), after.get(k)] for k in set(before) | set(after) if before.get(k) != after.get(k)}
    print("ENVIRONMENT CHANGES " + json.dumps(changed, sort_keys=True), flush=True)
sys.exit(code)
"""


def _isolated() -> list[str] | None:
    """A command prefix that runs a program in a network namespace with only loopback, if possible."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return None
    probe = subprocess.run(["unshare", "--net", "--", "ip", "link", "set", "lo", "up"], capture_output=True)
    return ["unshare", "--net", "--", "sh", "-c", 'ip link set lo up && exec "$@"', "sh"] if probe.returncode == 0 else None


def test_starting_and_stopping_the_node_leaves_its_environment_untouched():
    prefix = _isolated()
    if prefix is None:
        pytest.skip("no network namespace here: the node cannot run with the discovery range unset safely")
    sim = VirtualBus(servos={1: X})
    path = sim.start()
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY")}
    env["ROS_STATIC_PEERS"] = ""  # as a robot's shell may have it: set, empty
    cmd = prefix + [sys.executable, "-c", WRAPPER, "--ros-args", "--params-file", str(CONFIG),
                    "-p", f"device_name:={path}", "-p", "latency_timer:=1", "-p", "init/servo_auto_search.max_id:=1",
                    "-p", PATIENT_SCAN, "-p", "verbose_ratio:=0"]
    proc = _start(cmd, env)
    try:
        proc.wait_for("handled", timeout=30)
        assert proc.stop() == 0, proc.output
    finally:
        if proc.proc.poll() is None:
            proc.proc.kill()
        sim.stop()
    line = proc.wait_for("ENVIRONMENT CHANGES")
    changed = json.loads(line.split("ENVIRONMENT CHANGES ", 1)[1])
    assert changed == {}, f"the node changed its environment: {changed}"


def _start(cmd: list[str], env: dict[str, str]) -> NodeProcess:
    """NodeProcess (which starts from this process's environment) with ``env`` as the whole
    environment: keys absent from ``env`` are absent in the node."""
    saved = dict(os.environ)
    try:
        for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY"):
            os.environ.pop(key, None)
        os.environ.update(env)
        return NodeProcess(cmd)
    finally:
        os.environ.clear()
        os.environ.update(saved)
