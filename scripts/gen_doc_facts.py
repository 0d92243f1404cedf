#!/usr/bin/env python3
"""Print the facts the code knows into the docs: lists and tables that must never be typed by hand.

A page holds a generated block between two markers, the block's name in both:

    <!-- BEGIN FACTS baud-rates (scripts/gen_doc_facts.py --write) -->
    ...
    <!-- END FACTS baud-rates -->

and this script renders each block from the code (``BLOCKS`` below). It also keeps the parameter
counts of recorded node logs (``parameters: 88 other parameters at their defaults, 11 set``) equal to
what the node would print now. ``test/test_docs.py`` runs ``--check``: a family, a baud rate, a mode or
a parameter added to the code and not to the page fails the tests until ``--write`` is run.

    scripts/gen_doc_facts.py --list      # the blocks and the pages that hold them
    scripts/gen_doc_facts.py --write     # refresh every block and count in docs/ and README.md
    scripts/gen_doc_facts.py --check     # exit 1 naming each page that is out of date

Needs no ROS.
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Callable, Dict, Iterable, List, Tuple

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from dynamixel_handler.bus.port import LINE_BAUDRATES, PROTOCOL1_BAUDRATES  # noqa: E402
from dynamixel_handler.config import SCHEMA  # noqa: E402
from dynamixel_handler.config_checks import USED_FAMILIES  # noqa: E402
from dynamixel_handler.control_table import (  # noqa: E402
    OPERATING_MODES,
    TORQUE,
    Model,
    ServoFamily,
    known_models,
    protocol1_models,
)

#: a block; its lines are indented as its BEGIN marker is (a block within a list item)
BLOCK = re.compile(r"^(?P<indent>[ ]*)(?P<begin><!-- BEGIN FACTS (?P<name>[\w-]+) \(scripts/gen_doc_facts\.py "
                   r"--write\) -->\n)(?P<body>.*?)^(?P=indent)(?P<end><!-- END FACTS (?P=name) -->)", re.S | re.M)
#: the node's start-up line about the parameters not shown (``ros/params.describe``)
COUNT = re.compile(r"parameters: (?:(?P<others>\d+) other parameters at their defaults, (?P<set>\d+) set:"
                   r"|all other (?P<all>\d+) parameters at their defaults)")
#: the parameters ``describe`` names on its first line, never counted among the others
ESSENTIALS = 4

#: items a robot developer looks for, each with the items that give it (any one will do) and how the
#: docs name it
NOTABLE = (
    (("present_current",), "present current"), (("goal_current",), "goal current"),
    (("current_limit",), "current limit"), (("goal_pwm",), "PWM goal"), (("profile_velocity",), "profiles"),
    (("velocity_limit",), "velocity limit"), (("acceleration_limit",), "acceleration limit"),
    (("drive_mode",), "drive mode"), (("bus_watchdog",), "bus watchdog"),
    (("hardware_error_status",), "hardware error bits"), (("homing_offset",), "homing offset"),
    (("moving_status",), "moving status"), (("secondary_id",), "secondary ID"), (("protocol_type",), "protocol type"),
    (("startup_configuration",), "startup configuration"), (("led", "led_red", "led_colour"), "LED"),
    (("led_red",), "RGB LED"), (("pwm_slope",), "PWM slope"),
)


def _models() -> List[Model]:
    return list(known_models()) + list(protocol1_models())


def _of(family: ServoFamily) -> List[Model]:
    return [m for m in _models() if m.family is family]


def _names(models: Iterable[Model], most: int = 6) -> str:
    names = [m.name for m in models]
    return ", ".join(names) if len(names) <= most else ", ".join(names[:most]) + f" and {len(names) - most} more"


def _rate(bps: int) -> str:
    return f"{bps:,}"


def _read_by(family: ServoFamily) -> str:
    if family.protocol == 2:
        return "Fast Sync Read or Sync Read, all servos at once"
    return "one Bulk Read for all its servos" if family.bulk_read else "one Read Data per servo"


def families() -> str:
    """Every family: how it is named, which protocol it speaks, how it is read and driven."""
    rows = ["| family | `init/used_servo_series.` | default | protocol | models | read by | command topics |",
            "|---|---|---|---|---|---|---|"]
    for f in USED_FAMILIES:
        topics = (f"`commands/{f.suffix}`, `command/{f.suffix}/*`, `commands/all`" if f.series_topics
                  else "`commands/all`, `command/{status,goal,gain,limit,extra}`")
        models = _of(f)
        rows.append(f"| {f.name} | `{f.title}` | {'true' if f.used_by_default else 'false'} | {f.protocol}.0 | "
                    f"{len(models)}: {_names(models)} | {_read_by(f)} | {topics} |")
    return "\n".join(rows) + "\n"


def used_families() -> str:
    """The rule on ``init/used_servo_series`` as ``config_checks`` applies it."""
    return (f"- at least one of `init/used_servo_series.{{{','.join(f.title for f in USED_FAMILIES)}}}` is true;\n")


def baud_rates() -> str:
    """The rates ``baudrate`` takes and the families whose servos can be set to each."""
    lines = [f"- `baudrate` is one of {', '.join(str(r) for r in LINE_BAUDRATES)} (bps); which families can be "
             "set to each:", "", "  | bps | families |", "  |---|---|"]
    for bps in LINE_BAUDRATES:
        fams = [f.name for f in USED_FAMILIES if any(bps in m.baud_rates.values() for m in _of(f))]
        note = " (Protocol 1.0 only)" if bps in PROTOCOL1_BAUDRATES else ""
        lines.append(f"  | {_rate(bps)} | {', '.join(fams)}{note} |")
    return "\n".join(lines) + "\n"


def _yes(family: ServoFamily, mode: str) -> str:
    models = _of(family)
    without = [m for m in models if mode not in m.modes]
    having = [m for m in models if mode in m.modes]
    if not having:
        return "—"
    if len(having) < len(without):
        return f"only {_names(having, 8)}"
    return "yes" if not without else f"yes (not {_names(without, 8)})"


def modes() -> str:
    """Which operating mode each family (and which of its models) can be switched to."""
    fams = list(USED_FAMILIES)
    rows = ["| mode string | Operating Mode value | " + " | ".join(f.name for f in fams) + " |",
            "|---|---|" + "---|" * len(fams)]
    for mode, value in OPERATING_MODES.items():
        rows.append(f"| `{mode}` | {value} | " + " | ".join(_yes(f, mode) for f in fams) + " |")
    return "\n".join(rows) + "\n"


def lacks() -> str:
    """The notable items a family's models have not (every model, or some)."""
    rows = ["| family | every model lacks | some models lack |", "|---|---|---|"]
    for f in USED_FAMILIES:
        models = _of(f)
        every, some = [], []
        for items, label in NOTABLE:
            without = [m for m in models if not any(m.has(item) for item in items)]
            if len(without) == len(models):
                every.append(label)
            elif without:
                some.append(f"{label} ({_names(without, 4)})")
        rows.append(f"| {f.name} | {', '.join(every) or '–'} | {'; '.join(some) or '–'} |")
    return "\n".join(rows) + "\n"


def torque() -> str:
    """The torque per ampere of each model with figures (``joint_state.effort_unit: Nm``)."""
    rows = ["| model | N·m per A | from (e-Manual) |", "|---|---|---|"]
    for name, f in TORQUE.items():
        rows.append(f"| {name} | {f.nm_per_a:.3g} | {f.kind} {f.torque_nm:g} N·m at {f.current_a:g} A, {f.volts:g} V "
                    f"([page]({f.source})) |")
    return "\n".join(rows) + "\n"


#: block name -> what renders it
BLOCKS: Dict[str, Callable[[], str]] = {
    "families": families, "used-families": used_families, "baud-rates": baud_rates, "modes": modes,
    "lacks": lacks, "torque": torque,
}


def _counts(text: str) -> str:
    others = len(SCHEMA) - ESSENTIALS

    def fix(m: re.Match) -> str:
        if m.group("all") is not None:
            return f"parameters: all other {others} parameters at their defaults"
        shown = int(m.group("set"))
        return f"parameters: {others - shown} other parameters at their defaults, {shown} set:"
    return COUNT.sub(fix, text)


def render(text: str) -> Tuple[str, List[str]]:
    """The page with every block and count as the code has them; the names of unknown blocks."""
    unknown: List[str] = []

    def fill(m: re.Match) -> str:
        name = m.group("name")
        if name not in BLOCKS:
            unknown.append(name)
            return m.group(0)
        indent = m.group("indent")
        body = "".join(indent + line if line.strip() else line for line in BLOCKS[name]().splitlines(True))
        return indent + m.group("begin") + body + indent + m.group("end")
    return _counts(BLOCK.sub(fill, text)), unknown


def pages() -> List[Path]:
    return sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


def used_blocks() -> Dict[str, List[str]]:
    """Block name -> the pages (relative paths) that hold it."""
    where: Dict[str, List[str]] = {name: [] for name in BLOCKS}
    for page in pages():
        for m in BLOCK.finditer(page.read_text(encoding="utf-8")):
            where.setdefault(m.group("name"), []).append(str(page.relative_to(ROOT)))
    return where


def main(argv: List[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", action="store_true", help="refresh the pages")
    group.add_argument("--check", action="store_true", help="exit 1 if a page is out of date")
    group.add_argument("--list", action="store_true", help="the blocks and where they are")
    args = ap.parse_args(argv)
    if args.list:
        for name, where in used_blocks().items():
            print(f"{name}: {', '.join(where) or '(not on any page)'}")
        return 0
    stale, status = [], 0
    for page in pages():
        text = page.read_text(encoding="utf-8")
        new, unknown = render(text)
        for name in unknown:
            print(f"{page.relative_to(ROOT)}: unknown block {name!r} (known: {', '.join(BLOCKS)})", file=sys.stderr)
            status = 1
        if new != text:
            stale.append(str(page.relative_to(ROOT)))
            if args.write:
                page.write_text(new, encoding="utf-8")
    if args.check and stale:
        print(f"out of date: {', '.join(stale)} (run scripts/gen_doc_facts.py --write)", file=sys.stderr)
        return 1
    if args.write:
        print(f"written: {', '.join(stale) or 'nothing (all up to date)'}")
    return status


if __name__ == "__main__":
    sys.exit(main())
