"""The servos' current settings as a ``servos`` block (ROS-free): what an owner tuned live, saved as
a parameters file to start with next time.

Each handled servo gets an entry ``id_<N>`` with its mode, the gains and limits its model has, its
profiles, homing offset and return delay, and its Drive Mode and Shutdown bits, read from the servo
and written in the units of the command messages (the names and units of ``servo_settings.FIELDS``),
so that the file loads back as it was saved (``--params-file``, after the robot's own file).
``items_of`` names what an entry reads, so that all of it is read at once (a sync read per layout).
"""
from __future__ import annotations

import datetime
from typing import Any, Callable, Iterable

from .. import units
from ..control_table import Model
from . import error_state
from .settings import BITS, FIELDS, LED, MODE, WATCHDOG

#: decimals kept of a value in physical units: far finer than a register unit of any item
DECIMALS = 4


def items_of(model: Model) -> list[str]:
    """The items :func:`entry_of` reads of ``model`` (to read them all at once first)."""
    own = [spec.item for spec in FIELDS.values() if spec.kind not in (MODE, LED, WATCHDOG, BITS)]
    return [item for item in dict.fromkeys(own + ["drive_mode", "shutdown"]) if model.has(item)]


def entry_of(model: Model, read: Callable[[str], "int | None"], mode: str | None) -> dict[str, Any]:
    """One servo's entry: {field: value} (nested for the bit fields), what the servo holds now;
    ``read`` reads an item of it (None: no answer, the item left out)."""
    out: dict[str, Any] = {} if mode is None else {"mode": mode}
    for field, spec in FIELDS.items():
        if spec.kind in (MODE, LED, WATCHDOG, BITS) or not model.has(spec.item):
            continue
        raw = read(spec.item)
        if raw is not None:
            out[field] = int(raw) if spec.type is int else _in_units(model, spec.item, raw)
    out.update(_bit_fields(model, read))
    return out


def _bit_fields(model: Model, read: Callable[[str], "int | None"]) -> dict[str, Any]:
    """Drive Mode and Shutdown as their fields."""
    out: dict[str, Any] = {}
    drive = read("drive_mode") if model.has("drive_mode") else None
    if drive is not None:
        decoded = units.decode_drive_mode([drive])
        out["drive_mode"] = {k: (bool(v[0]) if k != "profile_configuration" else str(v[0])) for k, v in decoded.items()}
    shutdown = read("shutdown") if model.has("shutdown") else None
    if shutdown is not None:
        flags = units.decode_shutdown([error_state.common_bits(model, shutdown)])
        out["shutdown"] = {k: bool(v[0]) for k, v in flags.items()}
    return out


def _in_units(model: Model, item: str, raw: int) -> float:
    return round(float(units.pulse_to_unit([model], item, [raw])[0]), DECIMALS) + 0.0


def servos_yaml(entries: Iterable[tuple[int, dict[str, Any]]], source: str) -> str:
    """A parameters file holding the ``servos`` block of ``entries`` (ID, entry), with a line
    saying where and when it was taken."""
    import yaml
    block = {f"id_{dxl_id}": entry for dxl_id, entry in entries}
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    text = str(yaml.safe_dump({"/**": {"ros__parameters": {"servos": block}}}, sort_keys=False, default_flow_style=False))
    return (f"# the servos' settings as read from {source} at {stamp} (dynamixel_handler)\n"
            "# load it after the robot's own parameters file: --params-file robot.yaml --params-file this.yaml\n" + text)


__all__ = ["DECIMALS", "entry_of", "items_of", "servos_yaml"]
