"""The virtual bus served by ``dynamixel_handler_sim`` in a process of its own, for a rig whose
simulator must see what the test process does not: a family plug-in on its path (``Rig(sim_env=)``).

It offers what the rig needs of a bus (``start``: the device; ``close``) and the simulator's
run-time commands (``command``: ``hwerr 1 0x01``, ``turn 1 90``, ...); the registers and the
instruction log stay in that process.
"""
from __future__ import annotations

import os
import subprocess
import sys
import threading
import time


class SimProcess:
    """``python -m dynamixel_handler.sim`` serving ``servos`` ({id: model number}) through ``link``,
    replies untimed, with ``env`` added to this process's environment."""

    def __init__(self, servos: dict[int, int], link: str, env: dict[str, str]) -> None:
        cmd = [sys.executable, "-m", "dynamixel_handler.sim", "--no-wire-timing", "--link", link,
               *(f"--servo={i}:{m}" for i, m in sorted(servos.items()))]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env={**os.environ, **env})
        #: what it wrote on stderr (its servos, the answers to commands, a plug-in's refusal), line by line
        self.lines: list[str] = []
        threading.Thread(target=self._read_stderr, daemon=True).start()
        self.device = (self.proc.stdout.readline() if self.proc.stdout else "").strip()
        if not self.device:
            self.proc.wait(timeout=10)
            raise RuntimeError("dynamixel_handler_sim printed no device:\n" + "\n".join(self.lines))
        deadline = time.monotonic() + 10.0
        while not any(line.startswith("serving") for line in self.lines) and time.monotonic() < deadline:
            time.sleep(0.01)  # its servos listed: the next line on stderr answers a command

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def start(self) -> str:
        return self.device

    def command(self, line: str, timeout: float = 10.0) -> str:
        """Send one run-time command and wait for its answer (a line on stderr)."""
        assert self.proc.stdin is not None
        seen = len(self.lines)
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        deadline = time.monotonic() + timeout
        while len(self.lines) == seen:
            if time.monotonic() > deadline:
                raise TimeoutError(f"dynamixel_handler_sim did not answer {line!r}")
            time.sleep(0.01)
        return self.lines[seen]

    def close(self) -> int:
        """Quit (its exit code)."""
        try:
            if self.proc.stdin is not None:
                self.proc.stdin.write("quit\n")
                self.proc.stdin.close()
            return self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            return self.proc.wait()
