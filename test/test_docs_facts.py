"""Facts the code knows are printed from the code into the docs (scripts/gen_doc_facts.py), and the
claims of README.md and docs/ that name such facts in prose agree with the code."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from dynamixel_handler.control_table import FAMILIES, PROTOCOL1_FAMILIES, known_models
from dynamixel_handler.sim.cli import build_parser

from support.scripts import load_script

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"


def _facts():
    return load_script("gen_doc_facts")


def _flat(path: Path) -> str:
    return " ".join(path.read_text(encoding="utf-8").split())


def test_every_generated_block_and_count_is_as_the_code_has_it():
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "gen_doc_facts.py"), "--check"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


def test_every_block_is_on_a_page():
    where = _facts().used_blocks()
    assert all(where.values()), f"blocks on no page: {[n for n, w in where.items() if not w]}"


def test_a_stale_block_and_a_stale_count_are_found(tmp_path):
    facts = _facts()
    page = ("x\n<!-- BEGIN FACTS modes (scripts/gen_doc_facts.py --write) -->\n| old |\n<!-- END FACTS modes -->\n"
            "[INFO] parameters: 85 other parameters at their defaults, 6 set:\n")
    new, unknown = facts.render(page)
    assert not unknown and "| old |" not in new and "| `current` | 0 |" in new
    others = len(facts.SCHEMA) - facts.ESSENTIALS
    assert f"parameters: {others - 6} other parameters at their defaults, 6 set:" in new
    _, unknown = facts.render("<!-- BEGIN FACTS nosuch (scripts/gen_doc_facts.py --write) -->\n"
                              "<!-- END FACTS nosuch -->\n")
    assert unknown == ["nosuch"]


def test_the_notable_items_exist_on_some_model():
    facts = _facts()
    models = facts._models()
    for items, label in facts.NOTABLE:
        for item in items:
            assert any(m.has(item) for m in models), f"{label}: no model has {item!r}"


def test_the_readme_counts_the_models_the_control_table_knows():
    n = re.search(r"(\d+) models, each listed", _flat(README)).group(1)
    assert int(n) == len(known_models())


def test_the_readme_says_which_protocol_1_families_are_read_with_one_bulk_read():
    text = _flat(README)
    m = re.search(r"([A-Z]+(?: and [A-Z]+)*) read with one Bulk Read, ([A-Z, ]+?) and ([A-Z]+) servo by servo", text)
    assert m, "README's Protocol 1.0 paragraph no longer says how each family is read"
    name = {f.title: f.title.rstrip("1") for f in PROTOCOL1_FAMILIES}  # "MX1" is written MX
    bulk = {name[f.title] for f in PROTOCOL1_FAMILIES if f.bulk_read}
    one_by_one = {name[f.title] for f in PROTOCOL1_FAMILIES if not f.bulk_read}
    assert set(m.group(1).split(" and ")) == bulk
    assert {s.strip() for s in m.group(2).split(",")} | {m.group(3)} == one_by_one


def test_the_virtual_bus_says_it_serves_both_protocols():
    assert PROTOCOL1_FAMILIES and FAMILIES
    assert "Protocol 2.0 and 1.0" in build_parser().description
    first = (DOCS / "virtual_bus.md").read_text(encoding="utf-8").split("\n\n")[1]
    assert "Protocol 1.0" in first


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to dashes."""
    text = re.sub(r"[`*]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def test_every_anchor_a_page_links_to_is_a_heading_of_that_page():
    pages = sorted(DOCS.glob("*.md")) + [README]
    anchors = {}
    for page in pages:
        text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
        slugs, seen = set(), {}
        for heading in re.findall(r"^#{1,6} (.+)$", text, flags=re.M):
            slug = _slug(heading)
            n = seen.get(slug, 0)
            slugs.add(slug if n == 0 else f"{slug}-{n}")
            seen[slug] = n + 1
        anchors[page.resolve()] = slugs
    broken = []
    for page in pages:
        text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or "#" not in target:
                continue
            file, anchor = target.split("#", 1)
            path = (page.parent / file).resolve() if file else page.resolve()
            if path in anchors and anchor not in anchors[path]:
                broken.append(f"{page.relative_to(ROOT)} -> {target}")
    assert not broken, "links to headings that do not exist: " + ", ".join(broken)


def test_a_block_said_to_be_recorded_by_the_walkthrough_is_one_it_runs():
    """docs/setup_tool.md: a console block whose comment says `--walkthrough` regenerates it runs a
    command the walk-through (scripts/setup_tool_pictures.py's FirstDay) runs."""
    source = (ROOT / "scripts" / "setup_tool_pictures.py").read_text(encoding="utf-8")
    at = "--device /tmp/ttyDXL --baud 1000000"
    source = source.replace("{at}", at).replace("{device}", "--device /tmp/ttyDXL")
    text = (DOCS / "setup_tool.md").read_text(encoding="utf-8")
    blocks = re.findall(r"<!-- skip: next \"recorded by scripts/setup_tool_pictures\.py --walkthrough[^\n]*\n```console\n"
                        r"\$ (\S+) ([^\n]+)", text)
    assert len(blocks) >= 10
    missing = []
    for program, args in blocks:
        if program == "dynamixel_handler_setup":
            if f'"{args.split(" --device")[0]}' not in source.replace("f\"", "\"") and args not in source:
                missing.append(args)
        elif program != "dynamixel_handler":
            missing.append(f"{program} {args}")
    assert not missing, f"blocks the walk-through does not run: {missing}"
