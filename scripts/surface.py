#!/usr/bin/env python3
"""Print the public surface of a checkout, one sorted line per thing a user names:

    param <name> <type> <default>      every parameter of config.SCHEMA
    ros <name>                         every topic, service and action name the node's code spells
    exec <name>                        every console script of setup.py
    setup <verb> [<option>]            every verb and option of dynamixel_handler_setup
    msg <file> <hash>                  every message, service and action definition

    scripts/surface.py [--root DIR]    (DIR: a checkout, default this one)

``scripts/docs_touched.py`` compares two commits' surfaces: a change to it must come with a change
to the docs in the same commit. The ROS names are read from the code's string literals (no node is
started), the rest by importing the checkout's own package (no ROS needed).
"""
from __future__ import annotations

import argparse
import ast
import hashlib
import re
import sys
from pathlib import Path
from typing import Iterator

ROS_NAME = re.compile(r"^(~/|/?dynamixel/)[\w/{}]+$")


def ros_names(root: Path) -> Iterator[str]:
    """String literals (and f-string parts) of ros/ that are ROS names the node uses."""
    for path in sorted((root / "dynamixel_handler" / "ros").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and ROS_NAME.match(node.value):
                yield f"ros {node.value}"


def params() -> Iterator[str]:
    from dynamixel_handler.config import SCHEMA
    for p in SCHEMA:
        yield f"param {p.name} {type(p.default).__name__} {p.default!r}"


def setup_verbs() -> Iterator[str]:
    from dynamixel_handler.setup_tool.cli import build_parser
    parser = build_parser()
    for action in parser._actions:
        for option in action.option_strings:
            yield f"setup - {option}"
        if isinstance(action, argparse._SubParsersAction):
            for verb, sub in action.choices.items():
                yield f"setup {verb}"
                for sub_action in sub._actions:
                    for option in sub_action.option_strings:
                        yield f"setup {verb} {option}"


def executables(root: Path) -> Iterator[str]:
    for name in re.findall(r'"(\w+) = \{PACKAGE\}', (root / "setup.py").read_text(encoding="utf-8")):
        yield f"exec {name}"


def messages(root: Path) -> Iterator[str]:
    folder = root / "dynamixel_handler_msgs"
    for path in sorted(folder.glob("*/*")):
        if path.suffix in (".msg", ".srv", ".action"):
            yield f"msg {path.relative_to(folder)} {hashlib.sha256(path.read_bytes()).hexdigest()[:12]}"


def surface(root: Path) -> list[str]:
    sys.path.insert(0, str(root))
    lines = set(ros_names(root)) | set(params()) | set(setup_verbs()) | set(executables(root)) | set(messages(root))
    return sorted(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    args = ap.parse_args(argv)
    print("\n".join(surface(args.root.resolve())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
