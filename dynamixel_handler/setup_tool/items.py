"""Control-table items by name, values in physical units: parsing ``170deg``, ``1.5rad``,
``300mA``, ``12.0V`` or a raw register value, the range a model's table allows, and the text of a
value (unit and raw). Scales come from the model (:mod:`dynamixel_handler.units`)."""
from __future__ import annotations

import math
import re

from ..control_table import Item, Model
from ..units import UNIT_OF_QUANTITY, conversion, quantity_of, under_one_step
from .errors import BadArguments, cut
from .values import coded, number

__all__ = ["find_item", "item_range", "parse_value", "show_value", "to_unit"]

#: unit a user may write -> (the quantity's own unit, factor to it)
_ALIASES: dict[str, dict[str, float]] = {
    "deg": {"deg": 1.0, "rad": 180.0 / math.pi, "rev": 360.0},
    "deg/s": {"deg/s": 1.0, "rad/s": 180.0 / math.pi, "rpm": 6.0, "rev/min": 6.0},
    "deg/s^2": {"deg/s^2": 1.0, "deg/s2": 1.0, "rad/s^2": 180.0 / math.pi, "rad/s2": 180.0 / math.pi},
    "mA": {"mA": 1.0, "A": 1000.0},
    "%": {"%": 1.0},
    "V": {"V": 1.0, "mV": 0.001},
    "degC": {"degC": 1.0, "C": 1.0},
    "us": {"us": 1.0, "ms": 1000.0},
    "ms": {"ms": 1.0, "s": 1000.0},
    "s": {"s": 1.0, "ms": 0.001},
}
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*$")
_MAX_ID = 252


def find_item(model: Model, name: str) -> Item:
    """The item by name (``-`` or ``_``, any case); BadArguments listing near names otherwise."""
    key = name.strip().lower().replace("-", "_")
    if key in model.items:
        return model.items[key]
    near = [n for n in model.items if key in n][:6]
    hint = f" (did you mean {', '.join(near)}?)" if near else " (`info ID` lists them)"
    raise BadArguments(f"{model.name} has no control-table item '{cut(name)}'{hint}")


def unit_of(model: Model, item: Item) -> str:
    """The physical unit of ``item`` on ``model`` ("" when it stays raw)."""
    kind = quantity_of(item.name)
    if kind == "raw":
        return ""
    _, scale = conversion([model], item.name)
    return UNIT_OF_QUANTITY[kind] if math.isfinite(float(scale[0])) else ""


def to_unit(model: Model, item: Item, raw: int) -> float | None:
    """The raw value in the item's unit, None when it has none."""
    if not unit_of(model, item):
        return None
    offset, scale = conversion([model], item.name)
    return (raw - float(offset[0])) * float(scale[0])


def item_range(model: Model, item: Item) -> tuple[int, int]:
    """Lowest and highest raw value the model's table allows for ``item`` (the register's bytes,
    narrowed for IDs and for positions to the model's pulse range)."""
    if item.name == "id":
        return 0, _MAX_ID
    if item.name in ("min_position_limit", "max_position_limit") and model.position_max_pulse:
        return model.position_min_pulse, model.position_max_pulse
    return item.min_raw, item.max_raw


def _allowed(model: Model, item: Item) -> dict[int, str] | None:
    """Register values an item takes from a list (baud rate, operating mode), with their meaning."""
    if item.name == "baud_rate":
        return {value: f"{bps} bps" for value, bps in model.baud_rates.items()}
    if item.name == "operating_mode" and model.operating_modes:
        return {value: model.mode_name(value) or f"mode {value}" for value in model.operating_modes}
    return None


def parse_value(model: Model, item: Item, text: str, who: str, raw: bool = False) -> int:
    """The raw register value for ``text``: a number with a unit converted with the model's scale;
    a bare whole number is the register value of an item without a unit, or with ``raw`` (``--raw``);
    for an item with a unit it is refused with both readings. BadArguments (one line naming ``who``)
    when it is not a value of the item or out of the range the model's table allows."""
    match = _NUMBER.match(text)
    if match is None:
        raise BadArguments(f"{who}: '{cut(text)}' is not a value for {item.name} (a number, with a unit or raw)")
    number, unit = float(match.group(1)), match.group(2)
    own = unit_of(model, item)
    if not math.isfinite(number):
        raise BadArguments(f"{who}: '{cut(text)}' is not a finite number")
    if unit and raw:
        raise BadArguments(f"{who}: --raw takes a register value, not '{cut(text)}'")
    if unit:
        value = _converted(model, item, number, unit, who)
    elif number != int(number):
        raise BadArguments(f"{who}: {item.name} takes a whole raw value or a value with its unit"
                           f"{f' ({own})' if own else ''}, got '{cut(text)}'")
    elif own and not raw:
        raise BadArguments(f"{who}: {item.name} is in {own}: {_both(model, item, int(number), own)}")
    else:
        value = int(number)
    check_raw(model, item, value, who, text)
    return value


def _both(model: Model, item: Item, number: int, own: str) -> str:
    """``90 = 90 deg? write 90deg, or --raw for register value 90 (= -172.1 deg)``."""
    reading = ""
    if item.min_raw <= number <= item.max_raw:
        reading = f" (= {show_value(model, item, number).split(' (raw')[0]})"
    return f"{number} = {number} {own}? write {number}{own}, or --raw for register value {number}{reading}"


def check_raw(model: Model, item: Item, raw: int, who: str, text: str | None = None) -> None:
    given = f"'{cut(text)}' (raw {cut(raw)})" if text is not None and text.strip() != str(raw) else cut(raw)
    allowed = _allowed(model, item)
    if allowed is not None and raw not in allowed:
        raise BadArguments(f"{who}: {item.name} = {given} is not one {model.name} takes "
                           f"({', '.join(f'{v} = {m}' for v, m in sorted(allowed.items()))})")
    lo, hi = item_range(model, item)
    if not lo <= raw <= hi:
        raise BadArguments(f"{who}: {item.name} = {given} is out of range for {model.name}: "
                           f"{show_value(model, item, lo)} .. {show_value(model, item, hi)}")


def _converted(model: Model, item: Item, number: float, unit: str, who: str) -> int:
    own = unit_of(model, item)
    if not own:
        raise BadArguments(f"{who}: {item.name} of {model.name} has no physical unit: give the raw value")
    factors = _ALIASES.get(own, {own: 1.0})
    factor = factors.get(unit) or factors.get(unit.lower()) or {k.lower(): v for k, v in factors.items()}.get(unit.lower())
    if factor is None:
        raise BadArguments(f"{who}: {item.name} is in {own}, not '{unit}' (write one of {', '.join(factors)})")
    offset, scale = conversion([model], item.name)
    pulses = number * factor / float(scale[0]) + float(offset[0])
    if under_one_step(model, item.name, number * factor):
        return 1  # a slow profile is the smallest step, never 0: the servo takes 0 for no limit
    return int(math.floor(pulses + 0.5)) if pulses >= 0 else -int(math.floor(-pulses + 0.5))


def show_value(model: Model, item: Item, raw: int) -> str:
    """``"170 deg (raw 3982)"``, a code or bit mask by name (``"position (3)"``,
    ``"1,000,000 bps (3)"``, ``"overload, overheating (0x24)"``), or the raw value."""
    text = coded(model, item, raw)
    if text is not None:
        return text
    value = to_unit(model, item, raw)
    if value is None:
        return str(raw)
    return f"{number(value)} {unit_of(model, item)} (raw {raw})"
