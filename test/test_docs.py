"""The documentation stays true to the code: the parameter tables of docs/parameters.md are what
scripts/gen_param_docs.py renders from config.SCHEMA, and links between docs lead somewhere."""
from __future__ import annotations

import re
from pathlib import Path

from dynamixel_handler.config import SCHEMA

from support.scripts import load_script

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def _generator():
    return load_script("gen_param_docs")


def test_parameter_tables_match_the_schema():
    gen = _generator()
    documented = gen.generated_part((DOCS / "parameters.md").read_text(encoding="utf-8"))
    assert documented == gen.render(), (
        "docs/parameters.md is out of date with dynamixel_handler/config.py SCHEMA: "
        "run scripts/gen_param_docs.py --write")


def test_every_parameter_has_exactly_one_row_with_its_default():
    gen = _generator()
    rows = [line for line in gen.render().splitlines()
            if line.startswith("| `") and not line.startswith(("| `servos.", "| `joints."))]
    names = [re.match(r"\| `([^`]+)`", row).group(1) for row in rows]
    assert names.count("device_name") == 1
    assert sorted(names) == sorted(p.name for p in SCHEMA)
    by_name = dict(zip(names, rows))
    for param in SCHEMA:
        assert f"`{gen.format_value(param.default)}`" in by_name[param.name], param.name


def test_every_item_of_the_servos_block_has_one_row():
    from dynamixel_handler.servo.settings import FIELDS
    rows = [line for line in _generator().render().splitlines() if line.startswith("| `servos.<servo>.")]
    assert [re.match(r"\| `servos.<servo>.([^`]+)`", row).group(1) for row in rows] == list(FIELDS)


def test_every_key_of_the_joints_block_has_one_row():
    from dynamixel_handler.joints.block import KEYS
    rows = [line for line in _generator().render().splitlines() if line.startswith("| `joints.<joint>.")]
    assert [re.match(r"\| `joints.<joint>.([^`]+)`", row).group(1) for row in rows] == list(KEYS)


def test_the_range_rules_name_what_the_node_accepts():
    """The prose rules beside the tables: the baud rates the node takes and the families it can be
    told to use, as the code has them."""
    from dynamixel_handler.bus.port import LINE_BAUDRATES
    from dynamixel_handler.config import USED_FAMILIES
    text = " ".join((DOCS / "parameters.md").read_text(encoding="utf-8").split())
    rates = re.search(r"`baudrate` is one of ([\d, ]+)", text).group(1)
    assert tuple(int(r) for r in rates.replace(",", " ").split()) == LINE_BAUDRATES
    families = re.search(r"at least one of `init/used_servo_series\.\{([^}]+)\}` is true", text).group(1)
    assert families.split(",") == [f.title for f in USED_FAMILIES]


def test_yaml_defaults_are_rendered_as_yaml():
    gen = _generator()
    assert gen.format_value(True) == "true"
    assert gen.format_value([-1]) == "[-1]"
    assert gen.format_value([0.0, 0.0, 180.0]) == "[0.0, 0.0, 180.0]"
    assert gen.format_value([""]) == '[""]'
    assert gen.format_value("/dev/ttyUSB0") == "/dev/ttyUSB0"


def test_relative_links_in_docs_lead_to_files_that_exist():
    broken = []
    for doc in sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]:
        text = re.sub(r"```.*?```", "", doc.read_text(encoding="utf-8"), flags=re.S)  # code is not links
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            path = (doc.parent / target.split("#")[0]).resolve()
            if not path.exists():
                broken.append(f"{doc.relative_to(ROOT)} -> {target}")
    assert not broken, "broken links: " + ", ".join(broken)


def test_the_models_page_lists_every_model_the_control_table_knows():
    gen = load_script("gen_models_doc")
    text = (DOCS / "models.md").read_text(encoding="utf-8")
    assert text == gen.render(), "docs/models.md is out of date: run scripts/gen_models_doc.py --write"
    from dynamixel_handler.control_table import known_models
    for model in known_models():
        assert f"| {model.number} | {model.name} |" in text
