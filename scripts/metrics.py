#!/usr/bin/env python3
"""Size and complexity of the package: modules over 400 lines, classes over 250 lines and
functions of cyclomatic complexity over 12 (radon). Prints one line per offender and a summary;
``--check`` exits 1 when any remain.

    python scripts/metrics.py [--check] [PATH ...]   (default: dynamixel_handler)
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from radon.complexity import cc_visit
from radon.visitors import Class

MODULE_LINES, CLASS_LINES, FUNCTION_CC = 400, 250, 12


def _offenders(path: Path) -> tuple[list[str], int, int, int]:
    text = path.read_text()
    lines = text.count("\n")
    found: list[str] = []
    modules = classes = functions = 0
    seen: set[int] = set()
    if lines > MODULE_LINES:
        found.append(f"{path}: module {lines} lines")
        modules += 1
    for block in cc_visit(text):
        if isinstance(block, Class):
            size = block.endline - block.lineno + 1
            if size > CLASS_LINES:
                found.append(f"{path}:{block.lineno}: class {block.name} {size} lines")
                classes += 1
            members = block.methods
        else:
            members = [block]
        for fn in members:
            for f in [fn, *getattr(fn, "closures", [])]:
                if f.lineno in seen:  # radon lists a method in its class and again on its own
                    continue
                seen.add(f.lineno)
                if f.complexity > FUNCTION_CC:
                    found.append(f"{path}:{f.lineno}: {f.fullname} complexity {f.complexity}")
                    functions += 1
    return found, modules, classes, functions


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 when an offender remains")
    ap.add_argument("paths", nargs="*", default=["dynamixel_handler"])
    args = ap.parse_args(argv)
    totals = [0, 0, 0]
    for root in map(Path, args.paths):
        for path in sorted(root.rglob("*.py") if root.is_dir() else [root]):
            found, *counts = _offenders(path)
            for line in found:
                print(line)
            totals = [a + b for a, b in zip(totals, counts)]
    print(f"modules > {MODULE_LINES} lines: {totals[0]}; classes > {CLASS_LINES} lines: {totals[1]}; "
          f"functions with complexity > {FUNCTION_CC}: {totals[2]}")
    return 1 if args.check and any(totals) else 0


if __name__ == "__main__":
    sys.exit(main())
