#!/usr/bin/env python3
"""Branch coverage of each module of the core and the command side, from its own unit tests, held
to a floor per module.

What is measured: the unit tests of ``test/core`` and ``test/commands`` (no Handler, no ROS node;
about 6 s) run once under ``coverage`` with branch measurement, each test file its own coverage
context. A module's figure counts only the test files that import it (the files
``test/test_unit_coverage.py`` already requires, found by the same reading of their imports):
what another part's tests happen to run through it does not count. The lines a module runs when it
is imported (its ``def`` and ``class`` lines, its constants) count for every module: every module
of both folders is imported before the first test. The figure is coverage's percentage with branch
measurement: the statements run and the branch directions taken, over all statements and
directions (``coverage report --branch``'s column), ``EXCLUDE_ALSO`` left out.

The floors are checked in (``test/coverage_floors.json``): a ratchet. A module below its floor
fails, and a module without a floor (a new one) must reach the file's ``default``. ``--update``
raises each floor to today's figure rounded down and adds the new modules that reach the
default; it never lowers a floor nor admits a module below the default: that is a change of the
file by hand, seen in review.

    scripts/coverage_gate.py             # the table, lowest first (own tests, all unit tests, floor)
    scripts/coverage_gate.py --check     # exit 1 naming each module below its floor (CI: test/test_unit_coverage.py)
    scripts/coverage_gate.py --update    # raise the floors to today's figures
    scripts/coverage_gate.py --missing dynamixel_handler/core/scan.py   # what its own tests miss

Run it after ``scripts/setup.sh`` with ``env.sh`` sourced (``scripts/test.sh`` does both).
"""

import argparse
import ast
import importlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import coverage
import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "dynamixel_handler"
# the package from this tree, also when env.sh was not sourced: which module a name a test imports
# comes from is asked of the package itself (``_defined_in``)
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
#: package folder -> the test folder whose files are its unit tests
UNIT_DIRS = {"core": "test/core", "commands": "test/commands"}
#: the front: the unit tests build no Handler (its parts are measured, ``core/parts.py`` included)
EXEMPT = frozenset({"dynamixel_handler/core/handler.py"})
FLOORS = ROOT / "test" / "coverage_floors.json"
#: lines that are not behaviour: type-checking imports, protocol stubs, the unreachable ends
EXCLUDE_ALSO = (r"if TYPE_CHECKING:", r"^\s*\.\.\.\s*$", r"assert_never\(", r"raise NotImplementedError")
IMPORT_CONTEXT = ""  # coverage's static context: what runs before the first test


# ---------------------------------------------------------------- which tests are a module's own
def modules() -> list[str]:
    """The modules held to a floor, as repository paths."""
    out = []
    for folder in UNIT_DIRS:
        for path in sorted((ROOT / PACKAGE / folder).glob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if path.name != "__init__.py" and rel not in EXEMPT:
                out.append(rel)
    return out


def dotted(path: str) -> str:
    return path.removesuffix(".py").replace("/", ".")


def _is_module(name: str) -> bool:
    parts = name.split(".")
    if parts[0] != PACKAGE:
        return False
    base = ROOT.joinpath(*parts)
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _defined_in(package: str, name: str) -> str:
    """The module a name imported from ``package`` comes from (``from dynamixel_handler.commands
    import Commander``: ``commands.commander``); the package itself when that cannot be told."""
    if _is_module(f"{package}.{name}"):
        return f"{package}.{name}"
    try:
        value = getattr(importlib.import_module(package), name)
    except (ImportError, AttributeError):
        return package
    if isinstance(value, ModuleType):
        return value.__name__
    owner = getattr(value, "__module__", None)
    return owner if isinstance(owner, str) and owner.startswith(package) else package


def imports_of(path: Path) -> tuple[set[str], set[str]]:
    """(package modules, ``support`` modules) that the file at ``path`` imports, anywhere in it."""
    found: set[str] = set()
    support: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            if node.module == "support":
                support.update(f"support.{alias.name}" for alias in node.names)
                continue
            if node.module.startswith(PACKAGE):
                names = [_defined_in(node.module, alias.name) for alias in node.names]
                if node.module == PACKAGE and any(a.name == "Handler" for a in node.names):
                    names.append("dynamixel_handler.core.handler")
                names.append(node.module)
            else:
                names = [node.module]
        else:
            continue
        for name in names:
            (support if name.split(".")[0] == "support" else found).add(name)
    return found, support


def unit_test_files() -> list[Path]:
    return sorted(p for folder in UNIT_DIRS.values() for p in (ROOT / folder).glob("test_*.py"))


def own_tests() -> dict[str, list[str]]:
    """Each module -> the unit test files (repository paths) that import it."""
    imported = {p.relative_to(ROOT).as_posix(): imports_of(p)[0] for p in unit_test_files()}
    return {m: sorted(t for t, names in imported.items() if dotted(m) in names) for m in modules()}


# ---------------------------------------------------------------- the run under coverage
# The pytest plugin of the run (``-p coverage_gate``): every module imported before the first test,
# then each test file its own context, its fixtures' set-up and tear-down included.
def pytest_sessionstart(session: pytest.Session) -> None:
    for path in modules():
        importlib.import_module(dotted(path))


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> None:
    cov = coverage.Coverage.current()
    if cov is not None:
        cov.switch_context(item.nodeid.split("::")[0])


def _rcfile(folder: Path) -> Path:
    rc = folder / "coveragerc"
    exclude = "\n    ".join(EXCLUDE_ALSO)
    sources = "\n    ".join(f"{PACKAGE}/{f}" for f in UNIT_DIRS)
    rc.write_text(f"[run]\nbranch = True\ndata_file = {folder / 'data'}\nsource =\n    {sources}\n"
                  f"[report]\nexclude_also =\n    {exclude}\n")
    return rc


def run_unit_tests(folder: Path) -> tuple[Path, int, str]:
    """(coverage's rc file, pytest's exit code, its output) of the unit tests run under coverage."""
    rc = _rcfile(folder)
    path = [str(ROOT / "scripts"), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(path))
    run = subprocess.run([sys.executable, "-m", "coverage", "run", f"--rcfile={rc}", "-m", "pytest", "-q",
                          "-p", "no:cacheprovider", "-p", "coverage_gate", *UNIT_DIRS.values()],
                         cwd=ROOT, env=env, capture_output=True, text=True)
    return rc, run.returncode, run.stdout + run.stderr


# ---------------------------------------------------------------- the figures
def own_contexts(files: list[str]) -> list[str]:
    """The contexts of a module's figure: the imports before the first test, then its own test files."""
    return [f"^{re.escape(IMPORT_CONTEXT)}$"] + [f"^{re.escape(t)}$" for t in files]


@dataclass(frozen=True)
class Figure:
    module: str
    own: float  #: percent from its own test files (and the imports)
    everyone: float  #: percent from all the unit tests
    statements: int
    branches: int
    tests: tuple[str, ...]


def _report(cov: coverage.Coverage, module: str, contexts: list[str] | None, folder: Path) -> dict[str, float]:
    out = folder / "report.json"
    cov.json_report(morfs=[str(ROOT / module)], outfile=str(out), contexts=contexts)
    totals: dict[str, float] = json.loads(out.read_text())["totals"]
    return totals


def figures(rc: Path, folder: Path, tests: dict[str, list[str]]) -> list[Figure]:
    cov = coverage.Coverage(config_file=str(rc))
    cov.load()
    out = []
    for module, files in tests.items():
        own = _report(cov, module, own_contexts(files), folder)
        everyone = _report(cov, module, None, folder)
        out.append(Figure(module, own["percent_covered"], everyone["percent_covered"], int(own["num_statements"]),
                          int(own.get("num_branches", 0)), tuple(files)))
    return out


def measure() -> tuple[list[Figure], int, str]:
    with tempfile.TemporaryDirectory(prefix="coverage_gate_") as tmp:
        rc, code, output = run_unit_tests(Path(tmp))
        if code != 0:
            return [], code, output
        return figures(rc, Path(tmp), own_tests()), code, output


# ---------------------------------------------------------------- the floors
@dataclass(frozen=True)
class Floors:
    default: int
    floors: dict[str, int]


def load_floors(path: Path = FLOORS) -> Floors:
    data = json.loads(path.read_text())
    return Floors(int(data["default"]), {k: int(v) for k, v in data["floors"].items()})


def save_floors(floors: Floors, path: Path = FLOORS) -> None:
    data = json.loads(path.read_text()) if path.exists() else {}
    data["default"] = floors.default
    data["floors"] = dict(sorted(floors.floors.items()))
    path.write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n")


def _pc(value: float) -> str:
    return f"{math.floor(value * 10) / 10:.1f}%"


def verdicts(found: list[Figure], floors: Floors) -> list[str]:
    """One line per module below its floor (or, without one, below the default), and per floor of a
    module that is gone."""
    lines = []
    rel = FLOORS.relative_to(ROOT).as_posix()
    for f in found:
        mine = floors.floors.get(f.module)
        own = "its own unit tests (" + (", ".join(f.tests) or "none imports it") + ")"
        if mine is not None and f.own < mine:
            lines.append(f"{f.module}: {_pc(f.own)} branch coverage from {own}, below its floor of {mine}% ({rel})")
        elif mine is None and f.own < floors.default:
            lines.append(f"{f.module}: {_pc(f.own)} branch coverage from {own}, below the {floors.default}% "
                         f"a module without a floor in {rel} must reach")
    known = {f.module for f in found}
    for gone in sorted(set(floors.floors) - known):
        lines.append(f"{gone}: has a floor in {rel} but is no longer a module of the core or the command side "
                     "(scripts/coverage_gate.py --update removes it)")
    return lines


def raised(found: list[Figure], floors: Floors) -> tuple[Floors, list[str]]:
    """The floors raised to today's figures rounded down (never lowered), new modules that reach the
    default added, the floors of modules gone removed; and a line per change or refusal."""
    new = dict(floors.floors)
    lines = []
    for f in found:
        today, mine = math.floor(f.own), floors.floors.get(f.module)
        if mine is None and today < floors.default:
            lines.append(f"{f.module}: {_pc(f.own)}, below the default {floors.default}%: not added (its tests first)")
        elif mine is None or today > mine:
            new[f.module] = today
            lines.append(f"{f.module}: floor {mine if mine is not None else 'none'} -> {today}%")
    for gone in sorted(set(floors.floors) - {f.module for f in found}):
        del new[gone]
        lines.append(f"{gone}: floor removed (no longer a module)")
    return Floors(floors.default, new), lines


def table(found: list[Figure], floors: Floors) -> str:
    rows = [f"{'module':<48} {'own':>7} {'all':>7} {'floor':>6} {'stmts':>6} {'branches':>8}  own tests"]
    for f in sorted(found, key=lambda f: (f.own, f.module)):
        mine = floors.floors.get(f.module)
        floor = f"{mine}%" if mine is not None else f"({floors.default}%)"
        rows.append(f"{f.module:<48} {_pc(f.own):>7} {_pc(f.everyone):>7} {floor:>6} {f.statements:>6} {f.branches:>8}  "
                    + (", ".join(Path(t).name for t in f.tests) or "-"))
    return "\n".join(rows)


def show_missing(module: str) -> int:
    """Coverage's report of one module from its own tests, with the lines and branches missed."""
    files = own_tests().get(module)
    if files is None:
        print(f"{module}: not a module held to a floor (one of: {', '.join(modules())})", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="coverage_gate_") as tmp:
        rc, code, output = run_unit_tests(Path(tmp))
        if code != 0:
            print(output, file=sys.stderr)
            return 1
        cov = coverage.Coverage(config_file=str(rc))
        cov.load()
        cov.report(morfs=[str(ROOT / module)], show_missing=True, contexts=own_contexts(files))
    print("own tests: " + (", ".join(files) or "none"))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    parser.add_argument("--check", action="store_true", help="exit 1 when a module is below its floor")
    parser.add_argument("--update", action="store_true", help="raise the floors to today's figures, rounded down")
    parser.add_argument("--missing", metavar="MODULE", help="the lines and branches a module's own tests miss")
    args = parser.parse_args(argv)
    if args.missing:
        return show_missing(args.missing)
    found, code, output = measure()
    if code != 0:
        print(output, file=sys.stderr)
        print(f"[coverage] the unit tests of {' and '.join(UNIT_DIRS.values())} failed under coverage "
              f"(pytest exit {code}): no figures", file=sys.stderr)
        return 1
    floors = load_floors()
    if args.update:
        floors, lines = raised(found, floors)
        save_floors(floors)
        print("\n".join(lines) or "[coverage] every floor is at today's figure")
        return 0
    if not args.check:
        print(table(found, floors))
    failures = verdicts(found, floors)
    for line in failures:
        print(f"[coverage] {line}", file=sys.stderr)
    if args.check and not failures:
        print(f"[coverage] {len(found)} modules at or above their floors")
    return 1 if failures and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
