#!/usr/bin/env python3
"""Print the value ranges of a local checkout of the ROBOTIS e-Manual (github.com/ROBOTIS-GIT/emanual):
per model page, each control-table row's item, default and Range (or Min / Max) column, and the
ranges its item sections give ("Value Range" tables, the ``{% include %}`` files followed). The
data of ``dynamixel_handler/control_table/_ranges.py`` was read from these columns; this prints them
again to compare with it.

    scripts/emanual_ranges.py EMANUAL_CHECKOUT [PAGE ...]

PAGE: a path under ``docs/en/dxl/`` such as ``x/xm430-w350.md`` (default: every page of x/, mx/, p/,
pro/ and y/). Output: tab-separated ``page  item  source  default  range  lo  hi`` (lo / hi empty
where the range is not two numbers, e.g. "-Velocity Limit(44) ~ Velocity Limit(44)").
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Iterator, List, Optional, Tuple

FAMILIES = ("x", "mx", "p", "pro", "y")
INCLUDE = re.compile(r"{%\s*include\s+(\S+)\s*%}")
LINK = re.compile(r"\[([^\]]*)\]\([^)]*\)")
SECTION = re.compile(r"^#+ .*?\*\*\[?([^*\](]+?)\s*\(\d[\d, ]*\)")
NUMBER = r"-?\s*\d[\d,]*"
SPAN = re.compile(rf"^({NUMBER})\s*~\s*({NUMBER})$")
LIST = re.compile(rf"^{NUMBER}(\s*,\s*{NUMBER})+$")


def expand(root: Path, text: str, depth: int = 0) -> str:
    """``text`` with its ``{% include %}`` files put in (``_includes/`` of the checkout; "dxl/..." of
    older pages is "en/dxl/...")."""
    def put(match: re.Match) -> str:
        name = match.group(1)
        for path in (root / "_includes" / name, root / "_includes" / "en" / name):
            if path.is_file() and depth < 5:
                return expand(root, path.read_text(encoding="utf-8"), depth + 1)
        return ""
    return INCLUDE.sub(put, text)


def snake(name: str) -> str:
    """A manual's item name as the package's ("Secondary(Shadow) ID" -> secondary_id)."""
    name = name.replace("(Shadow)", "").replace("Protocol Version", "Protocol Type")
    return re.sub(r"[^0-9A-Za-z]+", "_", name).strip("_").lower()


def cells(line: str) -> List[str]:
    text = LINK.sub(r"\1", line.strip().strip("|"))
    return [re.sub(r"<br\s*/?>", " ", c).replace("\\", "").replace("*", "").strip() for c in text.split("|")]


def bounds(text: str) -> Tuple[Optional[int], Optional[int]]:
    """(lo, hi) of "0 ~ 1,023", "2, 10" (its lowest and highest) or "3" (0 .. 3, as the tables write
    Startup Configuration); (None, None) for anything else."""
    text = " ".join(text.split()).split(" (")[0]
    span = SPAN.match(text)
    if span:
        return int(re.sub(r"[\s,]", "", span.group(1))), int(re.sub(r"[\s,]", "", span.group(2)))
    if LIST.match(text):
        values = [int(v.replace(" ", "")) for v in text.split(",")]
        return min(values), max(values)
    if re.fullmatch(r"\d+", text):
        return 0, int(text)
    return None, None


def rows(text: str) -> Iterator[Tuple[str, str, str, str]]:
    """(item, source, default, range) of the control tables and of the sections' range tables."""
    header: List[str] = []
    section = ""
    for line in text.splitlines():
        found = SECTION.match(line)
        if found:
            section = snake(found.group(1))
        if not line.lstrip().startswith("|"):
            header = []
            continue
        row = cells(line)
        if not header:
            header = [c.lower() for c in row]
            continue
        if set("".join(row)) <= set(":- "):
            continue
        yield from _row(header, row, section)


def _row(header: List[str], row: List[str], section: str) -> Iterator[Tuple[str, str, str, str]]:
    column = {name: k for k, name in enumerate(header)}
    get = lambda *names: next((row[column[n]] for n in names if n in column and column[n] < len(row)), "")  # noqa: E731
    name = get("data name", "name")
    if name:
        span = get("range") or (f"{get('min')} ~ {get('max')}" if "min" in column else "")
        if span and span != "-":
            yield snake(name), "table", get("default value", "initial value", "default"), span
    elif section:
        span = get("value range", "range", "values")
        if span and bounds(span)[0] is not None:
            yield section, "section", "", span


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkout", type=Path, help="a checkout of github.com/ROBOTIS-GIT/emanual")
    parser.add_argument("pages", nargs="*", help="pages under docs/en/dxl/ (default: x, mx, p, pro, y)")
    args = parser.parse_args(argv)
    base = args.checkout / "docs" / "en" / "dxl"
    if not base.is_dir():
        parser.error(f"{args.checkout}: no docs/en/dxl/ (not an e-Manual checkout)")
    pages = [base / p for p in args.pages] or sorted(p for f in FAMILIES for p in (base / f).glob("*.md"))
    print("page\titem\tsource\tdefault\trange\tlo\thi")
    for page in pages:
        text = expand(args.checkout, page.read_text(encoding="utf-8"))
        for item, source, default, span in rows(text):
            lo, hi = bounds(span)
            print("\t".join([str(page.relative_to(base)), item, source, default, " ".join(span.split()),
                             "" if lo is None else str(lo), "" if hi is None else str(hi)]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
