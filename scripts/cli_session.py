#!/usr/bin/env python3
"""Run the command-line session of docs/ros2_cli.md for real and print its transcript.

    source env.sh && python scripts/cli_session.py > /tmp/session.txt

Starts the virtual bus and the node as shell 1 of the doc does, runs each command of shell 2
(`scripts/ros_cli.py`), stops the node with SIGINT, then the launch-file part. Prints each
command after a `$ ` and what it printed, as the doc shows it; the doc's console blocks are
copied from this output by hand (log lines cut at the right, install paths as `<install>`).
Keeps DDS discovery on this machine and uses a ROS_DOMAIN_ID of its own.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(60 + os.getpid() % 30))
os.environ["PYTHONUNBUFFERED"] = "1"
os.environ["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"

ROOT = Path(__file__).resolve().parent.parent
CLI = [sys.executable, str(ROOT / "scripts" / "ros_cli.py")]


class Background:
    """A process whose output lines are kept as they come."""

    def __init__(self, cmd: list[str]) -> None:
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, text: str, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while not any(text in line for line in self.lines):
            if time.monotonic() > end or self.proc.poll() is not None:
                raise SystemExit(f"no '{text}' in:\n" + "\n".join(self.lines))
            time.sleep(0.05)

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGINT)
        self.proc.wait(30)
        time.sleep(0.2)


def shell(*args: str) -> None:
    shown = " ".join(a if " " not in a and "{" not in a else f'"{a}"' for a in args)
    print(f"$ python scripts/ros_cli.py {shown}", flush=True)
    out = subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=60, cwd=ROOT)
    print(out.stdout.rstrip("\n") + out.stderr.rstrip("\n"), flush=True)


def main() -> int:
    sim = Background(["dynamixel_handler_sim"])
    while not sim.lines:
        time.sleep(0.05)
    device = sim.lines[0]
    print(f"# shell 1\n$ dynamixel_handler_sim &\n{device}")
    print("$ dynamixel_handler --ros-args --params-file config/config_dynamixel_handler.yaml \\\n"
          f"    --params-file config/config_virtual_bus.yaml -p device_name:={device}", flush=True)
    node = Background(["dynamixel_handler", "--ros-args", "--params-file", "config/config_dynamixel_handler.yaml",
                       "--params-file", "config/config_virtual_bus.yaml", "-p", f"device_name:={device}"])
    node.wait_for("loop running")
    time.sleep(2.0)
    print("# shell 2")
    shell("topic", "hz", "/dynamixel/states")
    shell("topic", "echo", "/dynamixel/debug", "--once")
    shell("topic", "pub", "/dynamixel/shortcut", "dynamixel_handler_msgs/msg/DynamixelShortcut",
          "{command: 'TOFF', id_list: [2]}")
    shell("topic", "pub", "/dynamixel/command/x/position_control",
          "dynamixel_handler_msgs/msg/DynamixelControlXPosition",
          "{id_list: [1], position_deg: [90.0], profile_vel_deg_s: [120.0]}")
    time.sleep(2.0)
    shell("topic", "echo", "/dynamixel/debug", "--once")
    shell("param", "get", "/dynamixel_handler", "loop_rate")
    node.wait_for("ms/loop(", timeout=30)
    node.stop()
    print("# shell 1: the node's log\n" + "\n".join(node.lines), flush=True)

    print(f"# shell 1\n$ python scripts/ros_cli.py launch launch_dynamixel_handler.py name_space:=robot1 "
          f"device_name:={device}")
    launched = Background(CLI + ["launch", "launch_dynamixel_handler.py", "name_space:=robot1",
                                 f"device_name:={device}"])
    launched.wait_for("loop running")
    time.sleep(2.0)
    print("# shell 2")
    shell("topic", "hz", "/robot1/dynamixel/states")
    shell("param", "get", "/robot1/dynamixel_handler", "device_name")
    launched.wait_for("ms/loop(", timeout=30)
    launched.stop()
    print("# shell 1: the launched node's log\n" + "\n".join(launched.lines), flush=True)
    sim.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
