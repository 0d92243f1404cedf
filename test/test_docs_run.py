"""The command blocks of README.md and docs/ run as written, so the docs cannot drift from the product.

sybil (https://sybil.readthedocs.io) finds the blocks of each page; each page is one test whose
blocks run in order, in the repository root, as a reader would type them:

- ``bash`` blocks run with ``bash -e``; ``python`` blocks run as a script; ``console`` blocks are
  ``$ command`` lines whose shown output is compared with what the command prints.
- ``ros2 ...`` runs through a stand-in (``scripts/ros_cli.py``; ``ros2 run dynamixel_handler X`` is the
  installed executable X), since the ROS 2 command line is not on PyPI.
- Paths under ``/tmp/`` and the adapter ``/dev/ttyUSB0`` are redirected into the test's own directory,
  so a page that starts a virtual bus at ``/tmp/ttyDXL`` does not meet another run's.
- A directive in an HTML comment before a block says how it runs:
  ``<!-- doc-run: background until "TEXT" -->`` (started and left running until the page ends or
  ``<!-- doc-run: stop -->``; the test waits for TEXT in its output), ``<!-- doc-run: for 8 s expect
  "TEXT" -->`` (a command that runs until stopped: stopped once TEXT is printed, at most 8 s),
  ``<!-- doc-run: expect "TEXT" -->`` (runs to the end; TEXT must be printed). A ``console`` block's
  output lines containing ``...`` match anything in their place; ``<!-- doc-run: output varies -->``
  before a console block runs it without comparing. ``<!-- skip: next "why" -->`` leaves out a block
  that cannot run here (a real robot, a ROS install); its names are still checked by
  test_docs_refs.py.
"""
from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time
import unittest
from pathlib import Path

import pytest
from sybil import Sybil
from sybil.parsers.markdown import CodeBlockParser, SkipParser
from sybil.parsers.markdown.lexers import DirectiveInHTMLCommentLexer

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK_TIMEOUT = 120.0

ROS2_STANDIN = """#!/usr/bin/env bash
# ros2 for the docs' blocks on a machine set up from PyPI (no ros2cli there)
case "$1" in
  run) exe="$3"; shift 3; exec "$exe" "$@" ;;
  launch) shift; [ "$1" = dynamixel_handler ] && shift; exec python "$ROOT/scripts/ros_cli.py" launch "$@" ;;
  topic|param|service|action|lifecycle) exec python "$ROOT/scripts/ros_cli.py" "$@" ;;
  pkg) [ "$2" = prefix ] && echo "$ROOT/install/$3" && exit 0 ;;
esac
echo "ros2 $*: not available without a ROS install" >&2
exit 127
"""


class Runner:
    """The shell a page's blocks run in: its directory, its background processes, the next block's mode."""

    def __init__(self, page: Path) -> None:
        self.page = page
        self.tmp = Path(tempfile.mkdtemp(prefix="docs_run_"))
        bindir = self.tmp / "bin"
        bindir.mkdir()
        (bindir / "ros2").write_text(ROS2_STANDIN)
        (bindir / "ros2").chmod(0o755)
        self.env = dict(os.environ, ROOT=str(ROOT), PATH=f"{bindir}:{os.environ['PATH']}", PYTHONUNBUFFERED="1",
                        RCUTILS_LOGGING_BUFFERED_STREAM="0", ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                        DOC_TMP=str(self.tmp))
        self.background: list[tuple[subprocess.Popen, Path]] = []
        self.mode: dict = {}

    def source(self, text: str) -> str:
        text = re.sub(r"(?<![\w.])/tmp/", str(self.tmp) + "/", text)
        return text.replace("/dev/ttyUSB0", str(self.tmp / "ttyUSB0"))

    def _start(self, script: str, log: Path) -> subprocess.Popen:
        return subprocess.Popen(["bash", "-e", "-c", script], cwd=ROOT, env=self.env, stdout=log.open("w"),
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)

    def run(self, script: str, where: str, redirect: bool = True) -> str:
        mode, self.mode = self.mode, {}
        log = self.tmp / f"block{len(list(self.tmp.glob('block*')))}.log"
        proc = self._start(self.source(script) if redirect else script, log)
        if mode.get("kind") == "background":
            self.background.append((proc, log))
            self._wait_text(proc, log, mode["text"], where)
            return log.read_text(errors="replace")
        limit = mode.get("seconds", BLOCK_TIMEOUT)
        try:
            if "seconds" in mode and mode.get("text"):  # a command that runs until stopped: stopped once it said it
                end = time.monotonic() + limit
                while proc.poll() is None and time.monotonic() < end and mode["text"] not in log.read_text(errors="replace"):
                    time.sleep(0.1)
                limit = 0.0 if mode["text"] in log.read_text(errors="replace") else max(0.0, end - time.monotonic())
            proc.wait(limit)
        except subprocess.TimeoutExpired:
            self._stop(proc)
            if "seconds" not in mode:
                raise AssertionError(f"{where}: still running after {limit:.0f} s:\n{log.read_text(errors='replace')}")
        self._stop_group(proc)
        out = log.read_text(errors="replace")
        if "seconds" not in mode and proc.returncode != 0:
            raise AssertionError(f"{where}: exit status {proc.returncode}:\n{out}")
        if mode.get("text") and mode["text"] not in out:
            raise AssertionError(f"{where}: no {mode['text']!r} in the output:\n{out}")
        return out

    def _wait_text(self, proc: subprocess.Popen, log: Path, text: str, where: str) -> None:
        end = time.monotonic() + 60
        while time.monotonic() < end:
            out = log.read_text(errors="replace")
            if text in out:
                return
            if proc.poll() is not None:
                raise AssertionError(f"{where}: ended ({proc.returncode}) before printing {text!r}:\n{out}")
            time.sleep(0.1)
        raise AssertionError(f"{where}: no {text!r} within 60 s:\n{log.read_text(errors='replace')}")

    @staticmethod
    def _stop(proc: subprocess.Popen) -> None:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        Runner._stop_group(proc)

    @staticmethod
    def _stop_group(proc: subprocess.Popen) -> None:
        """What a finished block left running in the background (``cmd &``) stops with it."""
        try:
            os.killpg(proc.pid, signal.SIGINT)
            time.sleep(0.5)
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    def stop_all(self) -> None:
        for proc, _ in reversed(self.background):  # the node before the bus it runs on
            self._stop(proc)
        self.background.clear()


def _where(example) -> str:
    return f"{Path(example.path).relative_to(ROOT)}:{example.line}"


def _bash(example) -> None:
    example.namespace["runner"].run(example.parsed, _where(example))


def _python(example) -> None:
    runner = example.namespace["runner"]
    script = runner.tmp / "block.py"
    script.write_text(runner.source(example.parsed))
    runner.run(f"{shlex.quote(sys.executable)} {shlex.quote(str(script))}", _where(example), redirect=False)


def _matches(shown: list[str], got: list[str]) -> bool:
    pattern = "\n".join(".*" if line.strip() == "..." else re.escape(line).replace(re.escape("..."), ".*")
                        for line in shown)
    return re.fullmatch(pattern, "\n".join(got), re.S) is not None


def _console(example) -> None:
    runner = example.namespace["runner"]
    mode, runner.mode = runner.mode, {}
    compare = mode.pop("compare", True)
    commands: list[tuple[str, list[str]]] = []
    for line in example.parsed.rstrip("\n").split("\n"):
        if line.startswith("$ "):
            commands.append((line[2:], []))
        elif commands:
            commands[-1][1].append(line)
    assert commands, f"{_where(example)}: a console block without a '$ ' command"
    for command, shown in commands:
        runner.mode = dict(mode)
        out = runner.run(command, _where(example)).rstrip("\n").split("\n")
        if compare and not _matches([s.rstrip() for s in shown], [o.rstrip() for o in out]):
            raise AssertionError(f"{_where(example)}: $ {command}\nshown:\n" + "\n".join(shown) + "\ngot:\n" + "\n".join(out))


def _directive(example) -> None:
    runner = example.namespace["runner"]
    words = example.parsed
    if words.strip() == "stop":
        runner.stop_all()
        return
    text = re.search(r'"([^"]*)"', words)
    if words.startswith("background"):
        runner.mode = {"kind": "background", "text": text.group(1) if text else ""}
    elif words.startswith("for"):
        runner.mode = {"seconds": float(re.match(r"for (\d+(?:\.\d+)?) ?s", words).group(1)),
                       "text": text.group(1) if text else ""}
    elif words.startswith("expect"):
        runner.mode = {"text": text.group(1)}
    elif words.strip() == "output varies":
        runner.mode = {"compare": False}
    else:
        raise ValueError(f"{_where(example)}: unknown doc-run directive {words!r}")


class DirectiveParser:
    def __init__(self) -> None:
        self.lexer = DirectiveInHTMLCommentLexer(directive="doc-run")

    def __call__(self, document):
        for region in self.lexer(document):
            region.parsed = region.lexemes["arguments"]
            region.evaluator = _directive
            yield region


SYBIL = Sybil(parsers=[SkipParser(), DirectiveParser(), CodeBlockParser("bash", _bash),
                       CodeBlockParser("python", _python), CodeBlockParser("console", _console)])


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_the_blocks_of_the_page_run_as_written(page):
    document = SYBIL.parse(page)
    runner = Runner(page)
    document.namespace["runner"] = runner
    try:
        for example in document:
            try:
                example.evaluate()
            except unittest.SkipTest:
                continue  # a block marked 'skip: next'
    finally:
        runner.stop_all()
