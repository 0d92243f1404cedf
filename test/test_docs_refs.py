"""The docs name only what exists: every repository path, executable, launch file, test and
parameter that README.md, CONTRIBUTING.md and docs/ mention is checked against the tree, setup.py
and config.SCHEMA; docs/README.md indexes every page; and claims about the servos that the control
table can refute (the baud rate new servos arrive at) are checked against it. Topic names are
checked against a running node in test_docs_run.py."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from dynamixel_handler.config import ALIASES, SCHEMA

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *sorted(DOCS.glob("*.md"))]
TOP_DIRS = ("scripts/", "docs/", "config/", "launch/", "examples/", "bench/", "test/", "dynamixel_handler/",
            "dynamixel_handler_msgs/", ".ci/", "resource/")
PARAMS = {p.name for p in SCHEMA} | set(ALIASES)  # the original handler's other spellings load too
#: the first segment of every parameter name ("init", "pub_ratio", "dyn_comm" ...)
PARAM_GROUPS = {n.split("/")[0] for n in PARAMS if "/" in n}


def _text(page: Path) -> str:
    return page.read_text(encoding="utf-8")


def _line(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _where(page: Path, text: str, pos: int) -> str:
    return f"{page.relative_to(ROOT)}:{_line(text, pos)}"


def _pattern(token: str) -> bool:
    """A name written as a pattern or a placeholder, not one thing."""
    return any(c in token for c in "<>*{}[]…$") or ".." in token


def test_the_docs_pages_exist():
    assert all(p.exists() for p in PAGES), [str(p) for p in PAGES if not p.exists()]


def test_every_repository_path_the_docs_name_exists():
    missing = []
    for page in PAGES:
        text = _text(page)
        for m in re.finditer(r"(?<![\w/.~-])((?:%s)[\w./-]*)" % "|".join(re.escape(d) for d in TOP_DIRS), text):
            token = m.group(1).rstrip(".,;:)")
            if _pattern(text[m.start(): m.end() + 1]) or _pattern(token):
                continue
            target = ROOT / token.split("::")[0]
            if re.match(r"dynamixel_handler_msgs/(msg|srv|action)/\w+$", token):  # an interface's type name
                target = target.with_name(target.name + "." + target.parent.name)
            if not target.exists():
                missing.append(f"{_where(page, text, m.start())}: {token}")
    assert not missing, "paths named in the docs that do not exist:\n" + "\n".join(missing)


def test_every_test_the_docs_cite_exists():
    missing = []
    for page in PAGES:
        text = _text(page)
        for m in re.finditer(r"(test_\w+\.py)::(test_\w+)", text):
            files = list((ROOT / "test").rglob(m.group(1)))
            if not files or not any(re.search(rf"def {m.group(2)}\b", f.read_text(encoding="utf-8")) for f in files):
                missing.append(f"{_where(page, text, m.start())}: {m.group(0)}")
    assert not missing, "tests cited in the docs that do not exist:\n" + "\n".join(missing)


def _console_scripts() -> set[str]:
    return set(re.findall(r'f?"(\w+) = \{PACKAGE\}', (ROOT / "setup.py").read_text(encoding="utf-8")))


def test_every_executable_and_launch_file_the_docs_run_exists():
    scripts, launches = _console_scripts(), {p.name for p in (ROOT / "launch").iterdir()}
    assert "dynamixel_handler" in scripts and "dynamixel_handler_launch.py" in launches
    wrong = []
    for page in PAGES:
        text = _text(page)
        for m in re.finditer(r"ros2 (run|launch) dynamixel_handler ([\w.-]+)", text):
            known = scripts if m.group(1) == "run" else launches
            if m.group(2) not in known:
                wrong.append(f"{_where(page, text, m.start())}: {m.group(0)}")
    assert not wrong, "executables / launch files named in the docs that the package does not install:\n" + "\n".join(wrong)


def _known_parameter(name: str) -> bool:
    """A parameter of the node, or a map of them (``init/used_servo_series`` holds ``...series.X``)."""
    return name in PARAMS or any(p.startswith(name + ".") or p.startswith(name + "/") for p in PARAMS)


def test_every_parameter_the_docs_set_exists():
    """``-p name:=value`` on a command line, and backticked names that start like a parameter group
    (``init/expected_servo_num``, ``pub_ratio/present.pwm``), are parameters of the node."""
    unknown = []
    for page in PAGES:
        if page.name == "parameters.md":
            continue  # generated from the schema itself (test_docs.py)
        text = _text(page)
        found = [(m.start(), m.group(1)) for m in re.finditer(r"-p ['\"]?([\w/.]+):=", text) if m.group(1) != "name"]
        found += [(m.start(), m.group(1)) for m in re.finditer(r"`([a-z_]+/[\w/.]+)`", text)
                  if m.group(1).split("/")[0] in PARAM_GROUPS]
        for pos, name in found:
            if not _pattern(name) and not _known_parameter(name.rstrip(".")):
                unknown.append(f"{_where(page, text, pos)}: {name}")
    # the unify-baudrate tool has parameters of its own
    unknown = [u for u in unknown if not u.endswith((": target_baudrate", ": min_id", ": max_id", ": baudrate_list"))]
    assert not unknown, "parameters named in the docs that the node does not have:\n" + "\n".join(unknown)


def test_the_docs_index_lists_every_page():
    index = _text(DOCS / "README.md")
    unlisted = [p.name for p in sorted(DOCS.glob("*.md")) if p.name != "README.md" and f"({p.name})" not in index]
    assert not unlisted, f"docs/README.md does not list: {', '.join(unlisted)}"


def test_the_readme_links_the_docs_map_and_the_quick_start():
    readme = _text(ROOT / "README.md")
    assert "(docs/README.md)" in readme and "(docs/quick_start.md)" in readme and "(docs/models.md)" in readme


def _factory_bauds() -> dict[str, int]:
    """Each model's factory baud rate in bps, from the control table (as the virtual bus unboxes it)."""
    from dynamixel_handler.control_table import known_models
    from dynamixel_handler.sim.defaults import factory_defaults
    out = {}
    for model in known_models():
        code = factory_defaults(model, 1).get("baud_rate")
        if code is not None:
            out[model.name] = model.baud_rates[code]
    return out


def test_no_page_says_every_new_servo_arrives_at_one_rate_when_some_do_not():
    """'every new servo arrives at 57600' is false while one model leaves the factory at another
    rate (XL-320, XM335-T323: 1 Mbps). A sentence that names 57600 as what new servos come at must
    also name the exceptions the control table knows."""
    other = sorted(name for name, bps in _factory_bauds().items() if bps != 57600)
    assert other, "the control table should know models that leave the factory at another rate"
    false = []
    for page in PAGES:
        text = _text(page)
        for sentence in re.finditer(r"[^.\n]*(?:\n[^.\n]+)*?57[ ,]?600[^.\n]*(?:\n[^.\n]+)*?[.\n]", text):
            s = " ".join(sentence.group(0).split())
            claims_all = re.search(r"\b(every|all|each|any)\b[^.]*\b(new|factory|unboxed|out of the box)|"
                                   r"\b(new|unboxed) (servo|dynamixel)s?\b[^.]*\b(arrive|come|ship|start)|"
                                   r"\bservos? leaves? the factory", s, re.I)
            if claims_all and not any(name.split("-")[0] in s or name in s for name in other):
                false.append(f"{_where(page, text, sentence.start())}: {s[:160]}")
    assert not false, (f"sentences that say all new servos arrive at 57600 bps (not so for {', '.join(other)}):\n"
                       + "\n".join(false))


@pytest.mark.parametrize("package", [ROOT, ROOT / "dynamixel_handler_msgs"], ids=["dynamixel_handler", "dynamixel_handler_msgs"])
def test_each_package_ships_its_licence_and_a_changelog_of_its_version(package):
    """As ROS packages do: LICENSE with the licence package.xml declares, CHANGELOG.rst in the ROS
    changelog format whose newest entry is the version package.xml names (setup.py the same)."""
    xml = (package / "package.xml").read_text(encoding="utf-8")
    version = re.search(r"<version>([\d.]+)</version>", xml).group(1)
    name = re.search(r"<name>(\w+)</name>", xml).group(1)
    assert "<license>Apache-2.0</license>" in xml
    assert "Apache License" in (package / "LICENSE").read_text(encoding="utf-8")
    changelog = (package / "CHANGELOG.rst").read_text(encoding="utf-8").splitlines()
    assert changelog[1] == f"Changelog for package {name}" and set(changelog[0]) == {"^"}
    entries = [line for k, line in enumerate(changelog[:-1]) if re.fullmatch(r"-+", changelog[k + 1])]
    assert re.fullmatch(rf"{re.escape(version)} \(\d{{4}}-\d\d-\d\d\)", entries[0]), (entries[0], version)
    if package == ROOT:
        assert f'version="{version}"' in (ROOT / "setup.py").read_text(encoding="utf-8")
