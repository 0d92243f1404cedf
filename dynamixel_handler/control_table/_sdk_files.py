"""Read the machine-readable control tables shipped inside the ``dynamixel-sdk`` wheel.

The wheel carries ``dynamixel_easy_sdk/control_table/*.model`` files: a ``[type info]`` section
(position range), a ``[unit info]`` section and a ``[control table]`` section of tab-separated
``Address Size Data Name`` rows. Reading them at run time avoids retyping ~50 tables by hand;
what they lack is added in ``_facts.py``.
"""

from __future__ import annotations

import functools
import importlib.resources
import re
from dataclasses import dataclass
from importlib.resources.abc import Traversable
from typing import Dict, List, Tuple

# Rows whose names the product never addresses directly (indirect blocks are configured by name
# elsewhere, and their addresses move with X330 firmware 52, which a model number cannot tell).
_SKIPPED_PREFIXES = ("Indirect ",)


@dataclass(frozen=True)
class SdkTable:
    """One parsed ``.model`` file: rows as canonical name -> (address, size), plus type info."""

    rows: Dict[str, Tuple[int, int]]
    type_info: Dict[str, float]


def canonical_name(sdk_name: str) -> str:
    """Turn a manual/SDK data name ("Secondary(Shadow) ID") into our snake_case name."""
    name = sdk_name.replace("(Shadow)", "")
    name = re.sub(r"[^0-9A-Za-z]+", "_", name).strip("_").lower()
    return name


def _table_dir() -> Traversable:
    return importlib.resources.files("dynamixel_easy_sdk") / "control_table"


def _control_row(cells: List[str], rows: Dict[str, Tuple[int, int]]) -> None:
    """One ``Address Size Data Name`` row (the header and the skipped names are left out)."""
    if len(cells) < 3 or not cells[0].isdigit():
        return  # header row
    address, size, sdk_name = int(cells[0]), int(cells[1]), cells[2]
    if not sdk_name.startswith(_SKIPPED_PREFIXES):
        rows[canonical_name(sdk_name)] = (address, size)


def _type_row(cells: List[str], type_info: Dict[str, float]) -> None:
    """One ``name value`` row of the type info (the header is left out)."""
    if len(cells) >= 2:
        try:
            type_info[cells[0]] = float(cells[1])
        except ValueError:
            pass  # header row


@functools.lru_cache(maxsize=None)
def load_sdk_table(file_name: str) -> SdkTable:
    """Parse one ``.model`` file by name (e.g. ``"xm430_w350.model"``)."""
    text = (_table_dir() / file_name).read_text(encoding="utf-8")
    section = ""
    rows: Dict[str, Tuple[int, int]] = {}
    type_info: Dict[str, float] = {}
    for raw_line in text.splitlines():
        line = raw_line.strip()
        if line.startswith("[") and line.endswith("]"):
            section = line[1:-1].strip().lower()
        elif line and section == "control table":
            _control_row([c.strip() for c in raw_line.split("\t")], rows)
        elif line and section == "type info":
            _type_row([c.strip() for c in raw_line.split("\t")], type_info)
    if not rows:
        raise ValueError(f"control table file {file_name} holds no rows")
    return SdkTable(rows=rows, type_info=type_info)


@functools.lru_cache(maxsize=None)
def sdk_model_index() -> Dict[int, str]:
    """``dynamixel.model``: model number -> file name, as the wheel lists it."""
    text = (_table_dir() / "dynamixel.model").read_text(encoding="utf-8")
    index: Dict[int, str] = {}
    for line in text.splitlines():
        cells = line.split()
        if len(cells) >= 2 and cells[0].isdigit():
            index[int(cells[0])] = cells[1]
    return index
