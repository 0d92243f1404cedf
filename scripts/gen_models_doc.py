#!/usr/bin/env python3
"""Write docs/models.md: one table of every model the handler recognises, from the control table.

The page is generated so that it cannot drift from ``dynamixel_handler/control_table``:
``test/test_docs.py`` fails when docs/models.md differs from what this script renders.

    scripts/gen_models_doc.py            # print the page on stdout
    scripts/gen_models_doc.py --write    # write docs/models.md
    scripts/gen_models_doc.py --check    # exit 1 if docs/models.md is out of date

Needs no ROS.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Iterable, List

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from dynamixel_handler.control_table import (  # noqa: E402
    FAMILIES,
    PROTOCOL1_FAMILIES,
    Model,
    ServoFamily,
    known_models,
    protocol1_models,
)
from dynamixel_handler.control_table._sdk_files import sdk_model_index  # noqa: E402

DOC = ROOT / "docs" / "models.md"

#: items a robot developer looks for; a model without one "lacks" it
NOTABLE = (
    ("present_current", "current sensing"), ("goal_current", "current goal"), ("goal_pwm", "PWM goal"),
    ("profile_velocity", "profiles"), ("bus_watchdog", "bus watchdog"),
    ("hardware_error_status", "hardware error bits"), ("homing_offset", "homing offset"),
    ("velocity_limit", "velocity limit"),
)

HEAD = """# Every recognised model

Generated from `dynamixel_handler/control_table/` by `scripts/gen_models_doc.py --write`; do not edit by
hand. The handler reads each servo's Model Number at the scan; a model not listed here is reported as
unknown and left out. `dynamixel_handler_sim --list-models` lists the same models, and the virtual bus
simulates each of them (`dynamixel_handler_sim --servo ID:NAME`).

Columns: the scales are per register unit (pulse); "lacks" names what the spec's messages carry but the
model's table has not: those fields read back as "not supported" (NaN, 0, "" or false) and commands for
them are refused with one line. Addresses come from the control-table files shipped in the
`dynamixel-sdk` wheel where it has one ("SDK file"), else from our own table written after the
ROBOTIS e-Manual ("e-Manual"); unit scales, operating modes and factory values always from the
model's e-Manual page (`dynamixel_handler/control_table/`). So are the value ranges
(`dynamixel_handler/control_table/_ranges.py`: the Range column of the model's control table, or its
item sections) that `dynamixel_handler_setup` checks a value against before it writes it and the
virtual bus answers with a Data Range Error: the limits (velocity, acceleration, voltage, current,
PWM, temperature), Homing Offset, Moving Threshold, the gains, the profiles, IDs and the like; an
item the pages give no range keeps its register's byte range (`Model.byte_range_items` names them,
the module's docstring says where the pages disagree). See [units.md](units.md) for the families'
units and [compatibility.md](compatibility.md) for what the handler does where a rule cannot apply.
"""


def _num(value: float, digits: int = 4) -> str:
    if math.isnan(value):
        return "–"
    return f"{value:.{digits}g}"


def topics_of(family: ServoFamily) -> str:
    """Which command topics drive a family's servos."""
    if not family.series_topics:
        return "`commands/all`, `command/{status,goal,gain,limit,extra}` only"
    suffix = family.topics.suffix
    return f"`commands/{suffix}`, `command/{suffix}/*`, `commands/all`"


def modes_of(model: Model) -> str:
    """The modes a command may switch the model to (a model without current sensing has no current
    modes: the handler refuses them with one line)."""
    names = [name for name, value in sorted(model.mode_values.items(), key=lambda kv: kv[1])
             if name in model.modes and value in model.operating_modes]
    if math.isnan(model.current_ma_per_pulse):
        names = [n for n in names if n not in ("current", "cur_position")]
    return ", ".join(names)


def lacks(model: Model) -> str:
    missing = [what for name, what in NOTABLE if not model.has(name)]
    if model.has("present_current") and math.isnan(model.current_ma_per_pulse):
        missing.insert(0, "current sensing")
    if not model.has("present_current") and model.has("present_load") and "current sensing" in missing:
        missing[missing.index("current sensing")] = "current sensing (Present Load instead)"
    return ", ".join(dict.fromkeys(missing)) or "–"


#: models without an e-Manual page: where their table comes from instead
NO_MANUAL_PAGE = {1700: "model file `xc335_t332.model` of ROBOTIS' dynamixel_hardware_interface (no e-Manual page)"}


def source(model: Model) -> str:
    sdk = sdk_model_index().get(model.number)
    return f"SDK file `{sdk}`" if sdk else NO_MANUAL_PAGE.get(model.number, "e-Manual")


def rows(models: Iterable[Model]) -> List[str]:
    out = ["| number | name | family | driven by | position °/pulse | velocity °/s per unit | current mA per unit "
           "| operating modes | lacks | addresses from |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for m in models:
        out.append(f"| {m.number} | {m.name} | {m.family.title} | {topics_of(m.family)} | "
                   f"{_num(m.position_deg_per_pulse)} | {_num(m.velocity_deg_s_per_pulse)} | "
                   f"{_num(m.current_ma_per_pulse)} | {modes_of(m)} | {lacks(m)} | {source(m)} |")
    return out


def _rate(bps: int) -> str:
    return f"{bps / 1e6:g} M" if bps >= 1_000_000 else str(bps)


def baud_rows(models: Iterable[Model]) -> List[str]:
    """One row per family, set of rates and factory rate: which baud rates a model can be set to, and
    the one it leaves the factory at (the virtual bus unboxes each model at that rate)."""
    from dynamixel_handler.sim.defaults import factory_defaults
    groups: dict = {}
    for m in models:
        code = factory_defaults(m, 1).get("baud_rate")
        key = (m.family.title, tuple(sorted(m.baud_rates.values())), m.baud_rates.get(code))
        groups.setdefault(key, []).append(m.name)
    out = ["| family | models | baud rates (bps) | factory rate |", "|---|---|---|---|"]
    for (family, rates, factory), names in groups.items():
        listed = ", ".join(names) if len(names) <= 8 else f"{', '.join(names[:3])} and {len(names) - 3} more"
        out.append(f"| {family} | {listed} | {', '.join(_rate(r) for r in rates)} | "
                   f"{_rate(factory) if factory else '–'} |")
    return out


PROTOCOL1_HEAD = """## Protocol 1.0

The AX, RX, DX, EX and MX (Protocol 1.0 firmware) models, written after each model's e-Manual page
(`dynamixel_handler/control_table/_protocol1.py`, whose docstring says where the pages disagree:
MX-12W reports 360 where its page says 104, the EX-106+ position text is the AX's). They are kept
apart from the models above (`protocol1_models()`, not `known_models()`: a Protocol 1.0 model number
is looked up only for a servo that answered in Protocol 1.0). The node drives them beside Protocol
2.0 servos on one bus where `init/used_servo_series.AX`, `RX`, `DX`, `EX` or `MX1` is true (off by
default: the scan then pings each ID in Protocol 1.0 too), through the series-independent topics
(`/dynamixel/commands/all`, `/dynamixel/command/*`, `/dynamixel/shortcut`, `joint_commands`, the
services and the trajectory action); MX and EX are read with one Bulk Read, the others servo by
servo (Protocol 1.0 has no Sync Read). The virtual bus serves every one of them and every verb of
the set-up tool takes them. No Operating Mode register: the Angle Limits select the mode (both 0:
Wheel, `velocity`; both 4095 on MX: multi-turn, `ex_position`; Torque Control Mode Enable on
MX-64/106: `current`). Positions count from the middle of the range; Moving Speed, Present Speed and
Present Load carry the direction in bit 10. Bulk Read: MX and EX only.
"""


def protocol1_rows(models: Iterable[Model]) -> List[str]:
    out = ["| number | name | family | position °/pulse (range, middle) | velocity °/s per unit | current mA per unit "
           "| modes | bulk read | baud rates (factory) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for m in models:
        modes = ", ".join(sorted(m.mode_values, key=lambda k: m.mode_values[k]))
        rates = m.baud_rates
        factory = rates.get(m.factory.get("baud_rate", -1))
        span = f"{_num(m.position_deg_per_pulse)} (0..{m.position_max_pulse}, {m.position_zero_pulse})"
        out.append(f"| {m.number} | {m.name} | {m.family.title} | {span} | {_num(m.velocity_deg_s_per_pulse)} | "
                   f"{_num(m.current_ma_per_pulse)} | {modes} | {'yes' if m.family.bulk_read else 'no'} | "
                   f"{_rate(min(rates.values()))}..{_rate(max(rates.values()))} ({_rate(factory) if factory else '–'}) |")
    return out


def render() -> str:
    models = known_models()
    parts = [HEAD]
    counts = ", ".join(f"{f.title} {sum(m.family is f for m in models)}" for f in FAMILIES)
    parts.append(f"{len(models)} models: {counts}.\n")
    for family in FAMILIES:
        own = [m for m in models if m.family is family]
        if own:
            parts.append(f"## {family.title}\n")
            parts.append("\n".join(rows(own)) + "\n")
    parts.append("## Baud rates\n")
    parts.append("What each model can be set to (`dynamixel_handler_setup set-baud`, `baudrate`) and the rate it "
                 "leaves the factory at. A bus runs at one rate: new servos of a model whose factory rate differs "
                 "from the bus's are found by `dynamixel_handler_setup scan` or `init/baudrate_auto_set`.\n")
    parts.append("\n".join(baud_rows(models)) + "\n")
    old = protocol1_models()
    parts.append(PROTOCOL1_HEAD)
    counts = ", ".join(f"{f.title} {sum(m.family is f for m in old)}" for f in PROTOCOL1_FAMILIES)
    parts.append(f"{len(old)} models: {counts}.\n")
    parts.append("\n".join(protocol1_rows(old)) + "\n")
    return "\n".join(parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help="write docs/models.md")
    group.add_argument("--check", action="store_true", help="exit 1 if docs/models.md is out of date")
    args = ap.parse_args(argv)
    text = render()
    if args.write:
        DOC.write_text(text, encoding="utf-8")
        print(f"wrote {DOC.relative_to(ROOT)}")
    elif args.check:
        if not DOC.exists() or DOC.read_text(encoding="utf-8") != text:
            print("docs/models.md is out of date: run scripts/gen_models_doc.py --write", file=sys.stderr)
            return 1
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
