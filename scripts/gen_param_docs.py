#!/usr/bin/env python3
"""Print (or refresh) the parameter tables of docs/parameters.md from ``config.SCHEMA``.

The tables are generated so that they cannot drift from the code: ``test/test_docs.py`` fails
when docs/parameters.md differs from what this script renders.

    scripts/gen_param_docs.py            # print the tables (markdown) on stdout
    scripts/gen_param_docs.py --write    # replace the generated part of docs/parameters.md
    scripts/gen_param_docs.py --check    # exit 1 if docs/parameters.md is out of date

Needs no ROS: ``dynamixel_handler.config`` is plain Python.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Iterable

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "parameters.md"
BEGIN = "<!-- BEGIN GENERATED PARAMETER TABLES (scripts/gen_param_docs.py --write) -->"
END = "<!-- END GENERATED PARAMETER TABLES -->"

#: section key -> heading; sections come out in the order SCHEMA first uses them
TITLES = {
    "general": "Bus, loop and general behaviour",
    "dyn_comm": "Communication retries (`dyn_comm/*`)",
    "init": "Start-up (`init/*`)",
    "term": "Shutdown (`term/*`)",
    "safety": "Safety (`safety/*`)",
    "default": "Values written at start-up (`default/*`)",
    "pub_ratio": "Read and publish ratios (`pub_ratio/*`)",
    "method": "Bus methods (`method/*`)",
    "option/external_port": "External ports (`option/external_port.*`)",
    "option/imu_opencr": "OpenCR IMU (`option/imu_opencr.*`, accepted for compatibility only)",
    "verbose": "Log switches (`verbose/*`)",
    "joint_state": "Joint states (`joint_state.*`)",
    "diagnostics": "Diagnostics (`diagnostics.*`)",
    "servos_snapshot": "Saving the servos block (`servos_snapshot.*`)",
}
#: the heading and the text before the table of the servos block's items (``servo_settings.FIELDS``)
SERVOS_TITLE = "### Per-servo settings (`servos.<servo>.<item>`)"
SERVOS_TEXT = (
    "One entry per servo, `<servo>` being `id_<N>` or a joint name of `joint_state.names`; nested items "
    "(`drive_mode`, `shutdown`, `led`) may be given as a map (`drive_mode: {reverse_mode: true}`) or dotted "
    "(`-p servos.id_1.drive_mode.reverse_mode:=true`). No entry has a default: an item not given is left as "
    "the servo holds it. See [the servos block](#the-servos-block-per-servo-settings) for when each is "
    "written and how it is checked.")


def section_of(name: str) -> str:
    """The section a parameter name belongs to (its first path segment, or 'general')."""
    head = name.split(".")[0]
    if head.startswith("option/"):
        return head
    if "/" in head:
        return head.split("/")[0]
    if "." in name:
        return head
    return "general"


def format_value(value: Any) -> str:
    """A default as it would be written in a YAML parameter file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) if not isinstance(v, str) else f'"{v}"' for v in value) + "]"
    if isinstance(value, str):
        return value if value else '""'
    return repr(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def render(schema: Iterable | None = None) -> str:
    """Markdown: one table per section, every parameter once, in SCHEMA order within a section."""
    if schema is None:
        sys.path.insert(0, str(ROOT))
        from dynamixel_handler.config import SCHEMA
        schema = SCHEMA
    sections: dict[str, list] = {}
    for param in schema:
        sections.setdefault(section_of(param.name), []).append(param)
    out: list[str] = []
    for key, params in sections.items():
        out += [f"### {TITLES.get(key, f'`{key}`')}", "",
                "| parameter | type | default | meaning |", "|---|---|---|---|"]
        out += [f"| `{p.name}` | {p.type} | `{format_value(p.default)}` | {_cell(p.description)} |" for p in params]
        out.append("")
    out += render_servos()
    out += render_joints()
    return "\n".join(out).rstrip("\n") + "\n"


#: the heading and the text before the table of the joints block's keys (``joints.block.KEYS``)
JOINTS_TITLE = "### Joints (`joints.<joint>.<key>`)"
JOINTS_TEXT = (
    "One entry per joint of the robot, named as in its URDF; `limits` may be given as a map "
    "(`limits: {position: [-1.5, 1.5]}`) or dotted (`-p joints.shoulder.limits.position:=[-1.5, 1.5]`). "
    "A paired joint names its servos in `ids`; a coupled set (a differential) is one entry per joint naming the same servos in `coupled`. "
    "See [robot_integration.md](robot_integration.md#the-joints-block-joints-as-the-urdf-has-them) for what each does.")


def render_joints() -> list[str]:
    """The keys a joints block entry may hold (``joints.block.KEYS``)."""
    sys.path.insert(0, str(ROOT))
    from dynamixel_handler.joints.block import KEYS
    out = [JOINTS_TITLE, "", JOINTS_TEXT, "", "| key | type | default | joints | meaning |", "|---|---|---|---|---|"]
    out += [f"| `joints.<joint>.{name}` | {kind} | {default} | {which} | {_cell(meaning)} |"
            for name, (kind, default, which, meaning) in KEYS.items()]
    return out + [""]


def render_servos() -> list[str]:
    """The items a servos block entry may hold, in the order ``servo_settings.FIELDS`` lists them."""
    sys.path.insert(0, str(ROOT))
    from dynamixel_handler.servo.settings import FIELDS
    out = [SERVOS_TITLE, "", SERVOS_TEXT, "", "| item | type | control-table item | meaning |", "|---|---|---|---|"]
    out += [f"| `servos.<servo>.{name}` | {f.type.__name__} | {f.item if f.kind != 'led' else 'led / led_<colour>'} "
            f"| {_cell(f.meaning)} |" for name, f in FIELDS.items()]
    return out + [""]


def generated_part(text: str) -> str:
    """The text between the markers of docs/parameters.md (ValueError if they are missing)."""
    try:
        start = text.index(BEGIN) + len(BEGIN)
        end = text.index(END, start)
    except ValueError:
        raise ValueError(f"{DOC} lacks the markers {BEGIN!r} ... {END!r}") from None
    return text[start:end].strip("\n") + "\n"


def refreshed(text: str) -> str:
    start = text.index(BEGIN) + len(BEGIN)
    end = text.index(END, start)
    return text[:start] + "\n\n" + render() + "\n" + text[end:]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help="update docs/parameters.md in place")
    group.add_argument("--check", action="store_true", help="exit 1 if docs/parameters.md is out of date")
    args = ap.parse_args(argv)
    if not (args.write or args.check):
        sys.stdout.write(render())
        return 0
    text = DOC.read_text(encoding="utf-8")
    if args.check:
        if generated_part(text) != render():
            print(f"{DOC.relative_to(ROOT)} is out of date: run scripts/gen_param_docs.py --write", file=sys.stderr)
            return 1
        return 0
    DOC.write_text(refreshed(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
