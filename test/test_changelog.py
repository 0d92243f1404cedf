"""A release check: every line of the CHANGELOG's top version names something that exists (a
parameter, a topic or service, an executable, a set-up tool verb or option, a file of the tree),
and every parameter-like name it gives is one the node declares."""
from __future__ import annotations

import re
from pathlib import Path

from dynamixel_handler.config import ALIASES, SCHEMA

ROOT = Path(__file__).resolve().parent.parent
PARAMS = {p.name for p in SCHEMA} | set(ALIASES)
PARAM_GROUPS = {n.split("/")[0].split(".")[0] for n in PARAMS}
#: every word the package's code has in a string or a name: a topic, a service, a verb, an option
_SOURCE = "\n".join(p.read_text(encoding="utf-8") for p in sorted((ROOT / "dynamixel_handler").rglob("*.py")))
_EXECUTABLES = set(re.findall(r'f?"(\w+) = \{PACKAGE\}', (ROOT / "setup.py").read_text(encoding="utf-8")))


def top_entries(text: str) -> tuple[str, list[str]]:
    """The top version's heading and its bullet lines (each joined into one line)."""
    sections = re.split(r"^(\d+\.\d+\.\d+ \([\d-]+\))\n-+\n", text, flags=re.M)
    version, body = sections[1], sections[2]
    return version, [" ".join(b.split()) for b in re.split(r"^\* ", body, flags=re.M) if b.strip()]


def _names(entry: str) -> list[str]:
    """What a line names: its ``literals`` and the path- or identifier-like words of its prose."""
    quoted = re.findall(r"``([^`]+)``", entry)
    words = re.findall(r"(?<![\w/.-])((?:[\w.-]+/)+[\w.*-]+|[a-z]+_[\w]+|--[a-z][\w-]*)", re.sub(r"``[^`]+``", "", entry))
    return [n.strip(".,;:()") for n in quoted + words]


def exists(name: str) -> bool:
    """The name is a parameter (or a group of them), a file, an executable or a word of the code."""
    bare = name.split(" ")[0].split(":=")[0].split("=")[0].rstrip(":")
    if bare in PARAMS or any(p.startswith(bare + "/") or p.startswith(bare + ".") for p in PARAMS):
        return True
    if (ROOT / bare).exists() or bare in _EXECUTABLES:
        return True
    leaf = bare.rsplit("/", 1)[-1].lstrip("-")
    return len(leaf) > 2 and (f'"{leaf}' in _SOURCE or f"'{leaf}" in _SOURCE or f"/{leaf}" in _SOURCE
                              or re.search(rf"\b{re.escape(leaf.replace('-', '_'))}\b", _SOURCE) is not None)


def _parameter_like(name: str) -> bool:
    head = name.split("/")[0].split(".")[0]
    return ("/" in name or "." in name) and head in PARAM_GROUPS and not name.endswith((".py", ".md", ".yaml"))


def test_every_line_of_the_top_version_names_something_that_exists():
    version, entries = top_entries((ROOT / "CHANGELOG.rst").read_text(encoding="utf-8"))
    assert entries, f"{version} has no lines"
    unnamed = [e[:100] for e in entries if not any(exists(n) for n in _names(e))]
    assert not unnamed, f"{version}: lines that name nothing the product has: {unnamed}"


def test_every_parameter_the_top_version_names_is_declared():
    version, entries = top_entries((ROOT / "CHANGELOG.rst").read_text(encoding="utf-8"))
    unknown = sorted({n for e in entries for n in _names(e) if _parameter_like(n) and not exists(n)})
    assert not unknown, f"{version} names parameters the node does not declare: {unknown}"


def test_the_check_finds_a_line_that_names_nothing_and_an_unknown_parameter():
    text = ("1.9.0 (2030-01-01)\n------------------\n* ``safety/no_such_switch`` stops the robot.\n"
            "* Faster in general.\n* ``dynamixel_handler_setup scan`` is quicker.\n\n1.8.0 (2029-01-01)\n---\n")
    version, entries = top_entries(text)
    assert version == "1.9.0 (2030-01-01)" and len(entries) == 3
    assert not any(exists(n) for n in _names(entries[1]))
    assert any(exists(n) for n in _names(entries[2]))
    assert [n for n in _names(entries[0]) if _parameter_like(n) and not exists(n)] == ["safety/no_such_switch"]
