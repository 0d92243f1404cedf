"""Regenerate the pictures of docs/setup_tool.md: ``scan`` and ``monitor`` as a terminal shows them.

Each picture is the real command's real output: a virtual bus (``dynamixel_handler_sim``, wire
timing on) stands in for the servos, ``dynamixel_handler_setup`` runs in a pseudo-terminal of
132 x 40 (so it draws its rich tables and progress bar as on a terminal; ``monitor`` gets a ``q``
after a few refreshes), and the screen it leaves is rebuilt from its bytes (carriage return, line
feed, cursor up, erase line; colours kept) and recorded with rich's ``Console(record=True)`` as SVG:

* ``docs/img/setup_scan.svg``: a full scan (every baud rate, IDs 0-252, Protocol 2.0 and 1.0) of
  five servos at three baud rates, two of them sharing ID 4, and an AX-12A (Protocol 1.0);
* ``docs/img/setup_monitor.svg``: ``monitor`` of three servos at 1 Mbps, one turning in velocity
  mode and one with an overheating error;
* ``docs/img/setup_plot.svg``: ``monitor --log`` of two of them for 3 s drawn by the ``plot`` verb
  (matplotlib), goal against present.

``--walkthrough`` runs the page's first day instead (three unboxed servos at ID 1: scan, assign-ids
plugging them in one at a time through the bus's ``add`` command, limits, a mode, info, backup,
monitor, a servo replaced and restored, several servos at once, ``--trace``, ``--log``/``--plot``,
the handler for a few seconds, then the joints calibrated, moved by hand through the bus's ``turn``
command) and prints each step's commands with their real output as the page's console blocks, to
paste when the tool's output changes (about 4 minutes); ``--calibration`` only the last step.

Usage: ``python scripts/setup_tool_pictures.py [--out docs/img] [--link /tmp/ttyDXL] [--walkthrough]``
(the pictures: about a minute).
"""
from __future__ import annotations

import argparse
import fcntl
import os
import re
import select
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import time

from rich.console import Console
from rich.text import Text

from dynamixel_handler.sim import VirtualBus

COLS, ROWS = 132, 40
TOOL = "dynamixel_handler_setup"
_TOKEN = re.compile(rb"\x1b\[[0-9;?]*[A-Za-z]|\r|\n|[^\x1b\r\n]+|\x1b")


def screen_of(raw: bytes) -> str:
    """The lines a terminal shows after ``raw`` (rich's output: it moves up and erases whole lines,
    so a line is only rewritten from its start); SGR colour codes are kept."""
    lines, row, overwrite = [""], 0, False
    for token in _TOKEN.findall(raw):
        if token == b"\n":
            row += 1
            lines += [""] * (row + 1 - len(lines))
        elif token == b"\r":
            overwrite = True
        elif token.startswith(b"\x1b["):
            if token.endswith(b"A"):
                row = max(0, row - int(token[2:-1] or b"1"))
            elif token.endswith(b"K"):
                lines[row] = ""
            elif token.endswith(b"m"):
                lines[row] += token.decode()
        elif token != b"\x1b":
            text = token.decode("utf-8", "replace")
            lines[row] = text if overwrite else lines[row] + text
            overwrite = False
    while lines and not re.sub(r"\x1b\[[0-9;]*m", "", lines[-1]).strip():
        lines.pop()
    return "\n".join(lines)


def run_in_terminal(argv: list[str], keys: bytes = b"", key_after_s: float | None = None,
                    timeout_s: float = 300.0) -> bytes:
    """Everything ``argv`` writes to a pseudo-terminal of COLS x ROWS (stdin, stdout and stderr)."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLS, 0, 0))
    env = {**os.environ, "COLUMNS": str(COLS), "LINES": str(ROWS), "TERM": "xterm-256color"}
    env.pop("NO_COLOR", None)
    proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=env, close_fds=True)
    os.close(slave)
    out, started, sent = b"", time.monotonic(), key_after_s is None
    while time.monotonic() - started < timeout_s:
        if not sent and time.monotonic() - started > key_after_s:  # type: ignore[operator]
            os.write(master, keys)
            sent = True
        ready, _, _ = select.select([master], [], [], 0.1)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the command ended and closed its side
                break
            if not data:
                break
            out += data
        elif proc.poll() is not None:
            break
    else:
        proc.kill()
    proc.wait()
    os.close(master)
    return out


def save_svg(command: str, raw: bytes, path: str, title: str) -> None:
    """The screen after ``raw``, under a prompt line with ``command``, as an SVG."""
    console = Console(record=True, width=COLS, force_terminal=True, color_system="truecolor",
                      file=open(os.devnull, "w"))
    console.print(Text.assemble(("$ ", "green"), command))
    console.print(Text.from_ansi(screen_of(raw)))
    console.save_svg(path, title=title)


def _bus(servos: list[tuple[int, int, int]], folder: str, link: str) -> tuple[subprocess.Popen, str]:
    """A virtual bus of (ID, model, bps) in its own process; returns it and its device path."""
    state = os.path.join(folder, "bus.json")
    bus = VirtualBus([(sid, model) for sid, model, _ in servos], wire_timing=False)
    for servo, (_, _, bps) in zip(bus.all_servos, sorted(servos, key=lambda s: s[0])):
        servo.write("baud_rate", {rate: v for v, rate in servo.baud_rates.items()}[bps])
    bus.save_state(state)
    bus.close()
    proc = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--state", state,
                             "--link", link], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    proc.stdout.readline()
    return proc, link


def _tool(*args: str) -> list[str]:
    return [sys.executable, "-m", "dynamixel_handler.setup_tool", *args]


def scan_picture(out: str, link: str) -> None:
    servos = [(1, 1020, 57600), (2, 1020, 57600), (3, 1200, 1_000_000), (4, 1070, 115200),
              (4, 1070, 115200), (7, 12, 1_000_000)]
    with tempfile.TemporaryDirectory() as folder:
        proc, device = _bus(servos, folder, link)
        try:
            raw = run_in_terminal(_tool("scan", "--device", device))
        finally:
            proc.communicate("quit\n", timeout=30)
    save_svg(f"{TOOL} scan --device {device}", raw, os.path.join(out, "setup_scan.svg"), f"{TOOL} scan")


def plot_picture(out: str, link: str) -> None:
    """``monitor --log --plot``: ID 2 turning in velocity mode, ID 1 holding its goal position."""
    servos = [(1, 1020, 1_000_000), (2, 1020, 1_000_000), (3, 1120, 1_000_000)]
    with tempfile.TemporaryDirectory() as folder:
        proc, device = _bus(servos, folder, link)
        try:
            common = ("--device", device, "--baud", "1000000", "--yes")
            for step in (("set-mode", "2", "velocity"), ("set", "2", "torque_enable", "1"),
                         ("set", "2", "goal_velocity", "20rpm"), ("set", "1", "torque_enable", "1"),
                         ("set", "1", "goal_position", "45deg")):
                subprocess.run(_tool(*step, *common), check=True, capture_output=True, timeout=60)
            subprocess.run(_tool("monitor", "1,2", "--count", "30", "--rate", "10", "--log",
                                 os.path.join(folder, "robot.csv"), "--device", device, "--baud", "1000000"),
                           check=True, capture_output=True, timeout=120)
            subprocess.run(_tool("plot", os.path.join(folder, "robot.csv"), os.path.join(out, "setup_plot.svg"),
                                 "position,velocity,current"), check=True, capture_output=True, timeout=120)
        finally:
            proc.communicate("quit\n", timeout=30)


def monitor_picture(out: str, link: str) -> None:
    servos = [(1, 1020, 1_000_000), (2, 1020, 1_000_000), (3, 1120, 1_000_000)]
    with tempfile.TemporaryDirectory() as folder:
        proc, device = _bus(servos, folder, link)
        try:
            common = ("--device", device, "--baud", "1000000", "--yes")
            for step in (("set-mode", "2", "velocity"), ("set", "2", "torque_enable", "1"),
                         ("set", "2", "goal_velocity", "30rpm"), ("set", "1", "torque_enable", "1")):
                subprocess.run(_tool(*step, *common), check=True, capture_output=True, timeout=60)
            assert proc.stdin is not None
            proc.stdin.write("hwerr 3 0x04\n")  # overheating
            proc.stdin.flush()
            time.sleep(0.5)
            raw = run_in_terminal(_tool("monitor", "--device", device, "--baud", "1000000"), b"q", 3.0)
        finally:
            proc.communicate("quit\n", timeout=30)
    save_svg(f"{TOOL} monitor --device {device} --baud 1000000", raw, os.path.join(out, "setup_monitor.svg"),
             f"{TOOL} monitor")


class FirstDay:
    """The walk-through of docs/setup_tool.md on a virtual bus at ``link``: each step's commands and
    output, keyed by step, as console blocks."""

    def __init__(self, link: str, folder: str, assembled: bool = False) -> None:
        self.link, self.folder = link, folder
        self.blocks: dict[str, str] = {}
        servos = ["--servo", "1:XM430-W350", "--servo", "2:XM430-W350", "--servo", "3:XM540-W270", "--baudrate",
                  "1000000"] if assembled else ["--servo", "1:XM430-W350", "--servo", "1:XM430-W350", "--servo",
                                                "1:XM540-W270"]
        self.sim = subprocess.Popen(
            ["dynamixel_handler_sim", "--link", link, "--state", "first_day.json", *servos],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=folder)
        assert self.sim.stdout is not None
        self.sim.stdout.readline()

    def show(self, step: str, command: str, output: str) -> None:
        self.blocks[step] = self.blocks.get(step, "") + f"$ {command}\n{output.rstrip()}\n"

    def bus(self, command: str) -> None:
        """A line on the virtual bus's stdin (``add 1 XM430-W350`` plugs a new servo in)."""
        assert self.sim.stdin is not None
        self.sim.stdin.write(command + "\n")
        self.sim.stdin.flush()
        time.sleep(0.3)

    def tool(self, step: str, args: str, cut=None, answer: str | None = None) -> None:
        """``args`` run in the walk-through's folder; ``answer``: what is typed at its question."""
        more = {"input": answer} if answer is not None else {}
        done = subprocess.run([TOOL, *args.split()], capture_output=True, text=True, timeout=600, cwd=self.folder,
                              **more)
        output = (done.stdout + done.stderr).rstrip() + ("" if done.returncode == 0 else f"\n[exit {done.returncode}]")
        self.show(step, f"{TOOL} {args}", cut(output) if cut else output)

    def assign_ids(self, args: str, plugs: list[str]) -> None:
        """``assign-ids`` answering each prompt: the next servo plugged in and Enter, then q."""
        proc = subprocess.Popen([TOOL, *args.split()], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, cwd=self.folder)
        assert proc.stdin is not None and proc.stdout is not None
        lines, left = [], list(plugs)
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("Connect one new servo"):
                answer = "q\n"
                if left:
                    self.bus(left.pop(0))
                    answer = "\n"
                lines.append("<Enter>\n" if answer == "\n" else answer)
                proc.stdin.write(answer)
                proc.stdin.flush()
        proc.wait()
        self.show("assign", f"{TOOL} {args}", "".join(lines))

    def session(self, step: str, args: str, answers: dict[str, tuple[list[str], str]]) -> None:
        """An interactive run: at each line that starts with a key of ``answers`` the bus commands
        given there are sent (a joint turned by hand), then the answer is typed (shown as typed,
        Enter as ``<Enter>``)."""
        proc = subprocess.Popen([TOOL, *args.split()], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, cwd=self.folder)
        assert proc.stdin is not None and proc.stdout is not None
        lines = []
        for line in proc.stdout:
            lines.append(line)
            key = next((k for k in answers if line.startswith(k)), None)
            if key is None:
                continue
            turns, answer = answers[key]
            for command in turns:
                self.bus(command)
            lines.append(f"{answer}\n" if answer else "<Enter>\n")
            proc.stdin.write(answer + "\n")
            proc.stdin.flush()
        proc.wait()
        self.show(step, f"{TOOL} {args}", "".join(lines) + ("" if proc.returncode == 0 else f"[exit {proc.returncode}]"))

    def calibration(self, at: str) -> None:
        """The arm assembled: ID 1 and 2 a shoulder and an elbow, moved through their ranges by
        hand (the bus's ``turn``) and held at their zero pose; ID 3 a wrist given a Homing Offset."""
        self.tool("calibrate", f"set 2 torque_enable 1 {at}")
        self.tool("calibrate", f"calibrate 1,2 --names shoulder,elbow --joints arm.yaml {at}")
        record = ["turn 1 -95", "turn 1 -20", "turn 1 85", "turn 2 -40", "turn 2 130", "turn 2 60"]
        self.session("calibrate", f"calibrate 1,2 --names shoulder,elbow --joints arm.yaml {at} --torque-off", {
            "torque goes off": ([], "y"), "move each joint": (record, ""),
            "hold the robot at its zero pose": (["turn 1 -5", "turn 2 45"], "")})
        with open(os.path.join(self.folder, "arm.yaml"), encoding="utf-8") as f:
            self.show("calibrate", "cat arm.yaml", f.read())
        self.session("homing", f"calibrate 3 --names wrist --joints wrist.yaml --homing-offset {at}", {
            "move each joint": (["turn 3 -150", "turn 3 100"], ""),
            "hold the robot at its zero pose": (["turn 3 30"], ""), "write the Homing Offset": ([], "y")})
        self.tool("homing", f"get 3 present_position {at}")

    def handler(self, seconds: float) -> None:
        params = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config",
                              "config_dynamixel_handler.yaml")
        args = ["-p", f"device_name:={self.link}", "-p", "baudrate:=1000000"]
        node = subprocess.Popen(["dynamixel_handler", "--ros-args", "--params-file", params, *args],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=self.folder)
        time.sleep(seconds)
        node.send_signal(signal.SIGINT)
        output, _ = node.communicate(timeout=30)
        self.show("handler", f"dynamixel_handler --ros-args --params-file config/config_dynamixel_handler.yaml "
                  f"{' '.join(args)}", output)

    def replacement(self, device: str) -> None:
        """ID 3 replaced by a new XM540-W270 from the box (ID 1, 57600 bps): restore finds it."""
        self.bus("remove 3")
        self.bus("add 1 XM540-W270")
        self.tool("replace_scan", f"scan {device} --protocol 2 --ids 0-9")
        self.tool("replace", f"restore robot.yaml {device} --dry-run")
        self.tool("replace", f"restore robot.yaml {device}", _question, answer="n\n")
        self.tool("replace", f"restore robot.yaml {device} --yes")

    def run(self) -> dict[str, str]:
        device = f"--device {self.link}"
        at = f"{device} --baud 1000000"
        try:
            self.tool("scan_all", f"scan {device}")
            self.bus("remove 1")  # unplug them all
            self.assign_ids(f"assign-ids 1 {at}", ["add 1 XM430-W350", "add 1 XM430-W350", "add 1 XM540-W270"])
            self.tool("scan_new", f"scan {at}")
            self.tool("limits", f"set 2 max_position_limit 170deg {at} --yes")
            self.tool("limits", f"set 2 min_position_limit -170deg {at} --yes")
            self.tool("limits", f"get 2 max_position_limit {at}")
            self.tool("mode", f"set-mode 3 ex_position {at} --yes")
            self.tool("info", f"info 2 {at}", _short_ram)
            self.tool("backup", f"backup robot.yaml {at}")
            with open(os.path.join(self.folder, "robot.yaml"), encoding="utf-8") as f:
                self.show("backup", "head -26 robot.yaml", "".join(f.readlines()[:26]))
            self.tool("monitor", f"monitor --once {at}")
            self.replacement(device)
            self.tool("several", f"set 1,2,3 profile_velocity 30rpm {at}")
            self.tool("several", f"get 1-3 profile_velocity {at}")
            self.tool("trace", f"get 2 present_position {at} --trace")
            self.tool("log", f"monitor 1,2 --count 20 --rate 10 --log robot.csv --plot robot.svg position,velocity "
                      f"{at} --json", lambda out: out.rsplit("\n}", 1)[-1].strip())
            with open(os.path.join(self.folder, "robot.csv"), encoding="utf-8") as f:
                self.show("log", "head -3 robot.csv", "".join(f.readlines()[:3]))
            self.handler(8.0)
            self.calibration(at)
        finally:
            self.sim.communicate("quit\n", timeout=30)
        return self.blocks


    def calibrated(self) -> dict[str, str]:
        """Only the calibration (``--calibration``), on servos already at their IDs and 1 Mbps."""
        try:
            self.calibration(f"--device {self.link} --baud 1000000")
        finally:
            self.sim.communicate("quit\n", timeout=30)
        return self.blocks


def _question(output: str) -> str:
    """Only the question a command asked (its table before it left out)."""
    return "...\n" + "\n".join(line for line in output.splitlines() if line.endswith("[y/N]"))


def _short_ram(output: str) -> str:
    """``info``'s output with the RAM items left out (their count said)."""
    head, _, ram = output.partition("\nRAM\n")
    lines = ram.splitlines()
    return f"{head}\nRAM\n... ({len(lines) - 2} RAM items) ...\n{lines[-1]}" if lines else output


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "docs", "img"))
    ap.add_argument("--link", default="/tmp/ttyDXL", help="the virtual bus's device link (shown in the pictures)")
    ap.add_argument("--only", choices=("scan", "monitor", "plot"))
    ap.add_argument("--walkthrough", action="store_true",
                    help="print the first day's commands and outputs (docs/setup_tool.md) instead")
    ap.add_argument("--calibration", action="store_true",
                    help="print only the calibration's (its three servos at 1 Mbps from the start)")
    args = ap.parse_args()
    if args.walkthrough or args.calibration:
        with tempfile.TemporaryDirectory() as folder:
            day = FirstDay(args.link, folder, assembled=args.calibration)
            for step, block in (day.calibrated() if args.calibration else day.run()).items():
                print(f"<!-- {step} -->\n```console\n{block.rstrip()}\n```\n")
        return 0
    os.makedirs(args.out, exist_ok=True)
    if args.only in (None, "scan"):
        scan_picture(args.out, args.link)
    if args.only in (None, "monitor"):
        monitor_picture(args.out, args.link)
    if args.only in (None, "plot"):
        plot_picture(args.out, args.link)
    print(f"pictures written to {os.path.normpath(args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
