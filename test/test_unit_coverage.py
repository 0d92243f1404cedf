"""Every part of the core and of the command side has a unit test of its own: some test file in
test/core or test/commands imports its module and builds no ``Handler`` and no ROS node (imports
neither the Handler nor rclpy, itself or through the ``support`` modules it uses). The modules are
listed from the file system, so a new one needs such a test from the start; ``core/handler.py`` (the
front) and the packages' ``__init__.py`` are exempt.

Each of those modules also keeps the branch coverage its own unit tests give it (the test files that
import it, as read here): ``scripts/coverage_gate.py --check`` against its floor in
``test/coverage_floors.json``, run here in a subprocess (about 10 s).

The unit tests build the core's parts as the Handler does (``support.parts``): the same settings
slices and the same wiring between the parts, compared here with a Handler's own."""
from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest

from support.scripts import load_script

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "dynamixel_handler"
TESTS = Path(__file__).resolve().parent
#: the package folders whose modules need a unit test, and the test folders that give them one
UNIT_DIRS = {"core": TESTS / "core", "commands": TESTS / "commands"}
EXEMPT = {"dynamixel_handler.core.handler"}
#: importing one of these (or ``Handler`` from the package) means a test builds the Handler or a node
FRONTS = ("dynamixel_handler.core.handler", "rclpy")
#: scripts/coverage_gate.py: which test files import a module is read once, there, for both checks
GATE = load_script("coverage_gate")
imports_of = GATE.imports_of


def modules_needing_a_test() -> list[str]:
    out = []
    for folder in UNIT_DIRS:
        for path in sorted((PACKAGE / folder).glob("*.py")):
            name = f"dynamixel_handler.{folder}.{path.stem}"
            if path.name != "__init__.py" and name not in EXEMPT:
                out.append(name)
    return out


def _builds_the_front(imported: set[str]) -> bool:
    return any(name == front or name.startswith(front + ".") for name in imported for front in FRONTS)


def front_free(path: Path, seen: set[Path] | None = None) -> bool:
    """The test file imports neither the Handler nor rclpy, nor does a ``support`` module it uses."""
    seen = set() if seen is None else seen
    if path in seen:
        return True
    seen.add(path)
    found, support = imports_of(path)
    if _builds_the_front(found):
        return False
    for name in support:
        helper = TESTS.joinpath(*name.split(".")).with_suffix(".py")
        if helper.is_file() and not front_free(helper, seen):
            return False
    return True


def unit_test_files() -> list[Path]:
    return sorted(p for folder in UNIT_DIRS.values() for p in folder.glob("test_*.py"))


def test_every_module_of_the_core_and_the_command_side_has_a_unit_test_without_the_handler():
    covered: dict[str, list[str]] = {}
    through_front: dict[str, list[str]] = {}
    for path in unit_test_files():
        found, _ = imports_of(path)
        into = covered if front_free(path) else through_front
        for name in found:
            into.setdefault(name, []).append(path.name)
    missing = []
    for module in modules_needing_a_test():
        if module in covered:
            continue
        if module in through_front:
            missing.append(f"{module}: imported only by tests that build the Handler or a node "
                           f"({', '.join(sorted(through_front[module]))})")
        else:
            missing.append(f"{module}: no test in test/core or test/commands imports it")
    assert not missing, "modules without a unit test of their own:\n  " + "\n  ".join(missing)


def test_the_listing_sees_package_imports_the_handler_and_helpers(tmp_path):
    """The check itself: a name from a package counts for the module that defines it, and a Handler
    reached through a helper counts as much as one imported directly."""
    test = tmp_path / "test_x.py"
    test.write_text("from dynamixel_handler.commands import Commander, CommandPaths\n"
                    "from dynamixel_handler.core import deferred as d\n"
                    "from dynamixel_handler.core.step import Step\n")
    found, _ = imports_of(test)
    assert {"dynamixel_handler.commands.commander", "dynamixel_handler.commands.paths",
            "dynamixel_handler.core.deferred", "dynamixel_handler.core.step"} <= found
    assert front_free(test)
    test.write_text("from dynamixel_handler import Handler\n")
    assert not front_free(test)
    test.write_text("import rclpy.node\n")
    assert not front_free(test)
    test.write_text("from support.handler_bench import handler_on_virtual_bus\n")
    assert not front_free(test)  # the helper builds a Handler
    test.write_text("from support.fake_bus import FakeBus\nfrom support.parts import build\n")
    assert front_free(test)
    assert "dynamixel_handler.core.handler" not in modules_needing_a_test()
    assert "dynamixel_handler.core.requests" in modules_needing_a_test()


# ---------------------------------------------------------------- the branch coverage of each
def test_each_module_keeps_the_branch_coverage_of_its_own_unit_tests():
    """The unit tests of test/core and test/commands under coverage: each module at or above its floor
    (a new module at the default), one line per module that is not."""
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "coverage_gate.py"), "--check"], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        pytest.fail("scripts/coverage_gate.py --check failed (--missing MODULE shows what a module's tests miss):\n"
                    + (run.stderr or run.stdout)[-6000:], pytrace=False)


def test_the_gate_holds_the_modules_this_check_lists():
    assert sorted(GATE.dotted(m) for m in GATE.modules()) == sorted(modules_needing_a_test())


def _figure(module: str, own: float, tests: tuple[str, ...] = ("test/core/test_x.py",)):
    return GATE.Figure(module, own, own, 10, 4, tests)


def test_the_gate_names_a_module_below_its_floor_a_new_one_below_the_default_and_a_floor_left_behind():
    floors = GATE.Floors(70, {"dynamixel_handler/core/a.py": 80, "dynamixel_handler/core/gone.py": 90,
                              "dynamixel_handler/core/low.py": 40})
    found = [_figure("dynamixel_handler/core/a.py", 79.96), _figure("dynamixel_handler/core/low.py", 41.0),
             _figure("dynamixel_handler/core/new.py", 65.0, ()), _figure("dynamixel_handler/core/ok.py", 70.0)]
    lines = GATE.verdicts(found, floors)
    assert len(lines) == 3, lines
    assert lines[0].startswith("dynamixel_handler/core/a.py: 79.9% branch coverage from its own unit tests "
                               "(test/core/test_x.py), below its floor of 80%")
    assert lines[1].startswith("dynamixel_handler/core/new.py: 65.0% branch coverage from its own unit tests "
                               "(none imports it), below the 70% a module without a floor")
    assert lines[2].startswith("dynamixel_handler/core/gone.py: has a floor")


def test_the_update_raises_floors_never_lowers_them_nor_admits_a_new_module_below_the_default():
    floors = GATE.Floors(70, {"dynamixel_handler/core/up.py": 80, "dynamixel_handler/core/down.py": 90,
                              "dynamixel_handler/core/gone.py": 90})
    found = [_figure("dynamixel_handler/core/up.py", 86.7), _figure("dynamixel_handler/core/down.py", 85.0),
             _figure("dynamixel_handler/core/new.py", 75.2), _figure("dynamixel_handler/core/weak.py", 69.9)]
    new, lines = GATE.raised(found, floors)
    assert new.floors == {"dynamixel_handler/core/up.py": 86, "dynamixel_handler/core/down.py": 90,
                          "dynamixel_handler/core/new.py": 75}
    assert any(line.startswith("dynamixel_handler/core/weak.py: 69.9%, below the default 70%: not added") for line in lines)
    assert GATE.verdicts(found, new) == [  # what stays for the author: the lowered one, the weak one
        line for line in GATE.verdicts(found, new) if line.startswith(("dynamixel_handler/core/down.py",
                                                                     "dynamixel_handler/core/weak.py"))]


# ---------------------------------------------------------------- the parts as the Handler builds them
def _settings():
    from dynamixel_handler.settings import Settings
    return Settings().but(loop__rate_hz=50, loop__no_response_auto_remove=3, method__fast_read=True,
                          method__split_write=False, scan__expected=2, start__bus_watchdog_ms=300.0,
                          term__servo_auto_stop=False, logs__max_width=3)


def test_the_unit_tests_hand_each_part_the_settings_slice_the_handler_does():
    from dynamixel_handler.core.handler import Handler

    from support import parts
    from support.fake_bus import XM430, FakeBus

    settings = _settings()
    h = Handler(FakeBus({1: XM430}), settings, logging.getLogger("test_unit_coverage"))
    built = parts.build(FakeBus({1: XM430}), settings)
    for name in ("reads", "watchdog", "recovery", "requests", "startup", "steps", "ending"):
        assert getattr(built, name).settings == getattr(h, name).settings, name
    assert built.writes.split_write == h.writes.split_write
    h.settings = settings.but(loop__rate_hz=7)  # replaced settings reach the parts as at the start
    assert h.watchdog.settings == parts.build(FakeBus({1: XM430}), settings.but(loop__rate_hz=7)).watchdog.settings


def _wiring(root: dict[str, object]) -> set[tuple[str, str, str]]:
    """(part, attribute, part it refers to) of every reference between the named parts."""
    names = {id(value): name for name, value in root.items()}
    out = set()
    for name, part in root.items():
        for attr, value in vars(part).items() if hasattr(part, "__dict__") else ():
            if id(value) in names and attr != "log":
                out.add((name, attr, names[id(value)]))
    return out


def _watchers(table, root: dict[str, object]) -> list[str]:
    """Who is told of a removal, in order: the part whose method it is ("front": the Handler's own line)."""
    names = {id(value): name for name, value in root.items()}
    return [names.get(id(getattr(w, "__self__", None)), "front") for w in table._removal_watchers]


def test_the_unit_tests_wire_the_parts_as_the_handler_does():
    from dynamixel_handler.core.handler import Handler

    from support import parts
    from support.fake_bus import XM430, FakeBus

    settings = _settings()
    log = logging.getLogger("test_unit_coverage")
    h = Handler(FakeBus({1: XM430}), settings, log)
    built = parts.build(FakeBus({1: XM430}), settings, log)
    theirs = {name: getattr(h, name) for name in parts.PART_NAMES}
    ours = {name: getattr(built, name) for name in parts.PART_NAMES}
    assert _wiring(ours) == _wiring(theirs)
    assert _wiring(ours)  # the comparison sees references (the parts do refer to each other)
    assert _watchers(built.table, {**ours, "front": built}) == _watchers(h.table, {**theirs, "front": h})
    assert set(built.intake.routes()) == set(h.intake.routes())
