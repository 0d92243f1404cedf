"""The checks of values before anything is sent: numbers parsed finite, input echoed cut short, each
item's range from the model's e-Manual facts (not only the register's bytes), min < max for each
limit pair, and the dangerous values that need the owner's word (``--force``).

Interface (``set``, ``set-mode`` and ``restore`` use the same):

* :func:`finite` / :func:`whole`: a number from the command line, BadArguments (one line) otherwise.
* :func:`cut`: user input as it is echoed in a message (long input shortened).
* :func:`needed` -> the items whose present value :func:`check` needs (limit partners, Shutdown,
  Drive Mode); read them from the servo first.
* :func:`problems` -> every :class:`Problem` of a set of new values; :func:`check` raises
  BadArguments for them (those that ``force`` allows excepted) before anything is written.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping

from ..control_table import Item, Model
from .errors import BadArguments, cut
from .items import show_value

__all__ = ["Problem", "cut", "finite", "whole", "manual_range", "needed", "problems", "check"]

#: (min item, max item): the servo refuses or misbehaves when min > max
LIMIT_PAIRS = (("min_position_limit", "max_position_limit"), ("min_voltage_limit", "max_voltage_limit"))
#: goals and the limit the servo holds each to (a goal beyond it is refused by the servo)
GOAL_LIMITS = {"goal_velocity": "velocity_limit", "goal_current": "current_limit", "goal_pwm": "pwm_limit"}
#: what a goal position is checked against (in the modes the position limits apply to)
_POSITION_LIMITS = ("operating_mode", "min_position_limit", "max_position_limit")
#: a protection lowered beyond its factory value needs --force: (item, +1 raising / -1 lowering is the danger)
_PROTECTIONS = {"temperature_limit": 1, "max_voltage_limit": 1, "min_voltage_limit": -1}
#: Secondary ID values that switch it off
_SECONDARY_OFF = 253


@dataclass(frozen=True)
class Problem:
    """One reason a value is not written: ``forcible`` ones ``--force`` allows."""

    item: str
    text: str
    forcible: bool = False


def finite(text: str, what: str) -> float:
    """``text`` as a finite number; BadArguments naming ``what`` otherwise (``inf``, ``1e400``, ``nan``)."""
    try:
        value = float(str(text).strip())
    except ValueError:
        raise BadArguments(f"{what}: '{cut(text)}' is not a number") from None
    if not math.isfinite(value):
        raise BadArguments(f"{what}: '{cut(text)}' is not a finite number")
    return value


def whole(text: str, what: str, lo: int, hi: int) -> int:
    """``text`` as a whole number in ``lo..hi``; BadArguments naming ``what`` otherwise."""
    value = finite(text, what)
    if value != int(value) or not lo <= value <= hi:
        raise BadArguments(f"{what}: '{cut(text)}' is not a whole number {lo}..{hi}")
    return int(value)


def manual_range(model: Model, item: Item) -> tuple[int, int]:
    """The lowest and highest value the model's e-Manual gives ``item`` (``Model.value_range``: the
    register's bytes where it gives none narrower); the position limits: the model's position range."""
    if item.name in ("min_position_limit", "max_position_limit") and model.position_max_pulse:
        return model.position_min_pulse, model.position_max_pulse
    return model.value_range(item.name)


def needed(model: Model, names: Iterable[str]) -> list[str]:
    """The items whose present value :func:`problems` needs for ``names`` (read them first)."""
    want: list[str] = []
    for name in names:
        for pair in LIMIT_PAIRS:
            if name in pair:
                want += [n for n in pair if n != name and model.has(n)]
        if name in ("shutdown", "drive_mode") and model.has(name):
            want.append(name)
        want += _goal_partners(model, name)
    return sorted(set(want))


def _goal_partners(model: Model, name: str) -> list[str]:
    if name in GOAL_LIMITS and model.has(GOAL_LIMITS[name]):
        return [GOAL_LIMITS[name]]
    return [n for n in _POSITION_LIMITS if model.has(n)] if name == "goal_position" else []


def problems(model: Model, new: Mapping[str, int], now: Mapping[str, int], dxl_id: int,
             other_ids: Iterable[int] = ()) -> list[Problem]:
    """Every problem of writing ``new`` (item -> raw) to the servo at ``dxl_id`` whose present
    values ``now`` holds (at least those :func:`needed` names); ``other_ids``: the other servos'
    IDs on the bus (a Secondary ID equal to one makes two servos answer as one)."""
    found: list[Problem] = []
    for name, raw in new.items():
        item = model.items.get(name)
        if item is None:
            found.append(Problem(name, f"{model.name} has no item {cut(name)}"))
            continue
        found += _one(model, item, raw, now, dxl_id, set(other_ids))
    merged = {**now, **new}
    for low, high in LIMIT_PAIRS:
        if (low in new or high in new) and low in merged and high in merged and merged[low] >= merged[high]:
            found.append(Problem(low if low in new else high,
                                 f"{low} ({_shown(model, low, merged[low])}) would not be below {high} "
                                 f"({_shown(model, high, merged[high])})"))
    return found + _goals(model, new, merged)


def _goals(model: Model, new: Mapping[str, int], merged: Mapping[str, int]) -> list[Problem]:
    """Goals beyond the limit the servo holds them to (it would answer a Data Limit Error)."""
    found = []
    for goal, limit in GOAL_LIMITS.items():
        if goal in new and limit in merged and abs(new[goal]) > merged[limit]:
            found.append(Problem(goal, f"{goal} = {_shown(model, goal, new[goal])} is beyond {limit} "
                                       f"({_shown(model, limit, merged[limit])})"))
    if "goal_position" in new and all(n in merged for n in _POSITION_LIMITS) and \
            model.mode_name(merged["operating_mode"]) in model.position_limited_modes:
        low, high, target = merged["min_position_limit"], merged["max_position_limit"], new["goal_position"]
        if not low <= target <= high:
            found.append(Problem("goal_position", f"goal_position = {_shown(model, 'goal_position', target)} is outside the "
                                                  f"position limits ({_shown(model, 'min_position_limit', low)} .. "
                                                  f"{_shown(model, 'max_position_limit', high)})"))
    return found


def _shown(model: Model, name: str, raw: int) -> str:
    return show_value(model, model.items[name], raw)


def _one(model: Model, item: Item, raw: int, now: Mapping[str, int], dxl_id: int, others: set[int]) -> list[Problem]:
    name = item.name
    lo, hi = manual_range(model, item)
    if not lo <= raw <= hi:
        return [Problem(name, f"{name} = {_shown(model, name, raw)} is outside what the e-Manual gives {model.name}: "
                              f"{_shown(model, name, lo)} .. {_shown(model, name, hi)}")]
    danger = _danger(model, item, raw, now, others - {dxl_id})
    return [Problem(name, danger, forcible=True)] if danger else []


def _danger(model: Model, item: Item, raw: int, now: Mapping[str, int], others: set[int]) -> str:
    """Why ``raw`` lowers a protection or makes two servos answer as one ("" when it does not)."""
    name = item.name
    factory = model.factory.get(name)
    worse = _PROTECTIONS.get(name)
    if worse is not None and factory is not None and (raw - factory) * worse > 0:
        return (f"{name} = {_shown(model, name, raw)} lowers a protection beyond its factory value "
                f"({_shown(model, name, factory)})")
    kept = now.get(name, 0) | (factory or 0)
    if name == "shutdown" and kept & ~raw:
        return (f"shutdown = {raw} clears protection bits 0x{kept & ~raw:02X} (the servo would no longer turn its "
                "torque off on those errors)")
    if name == "drive_mode" and (raw ^ now.get(name, raw)) & 1:
        return "drive_mode bit 0 reverses the direction it turns (a joint built for one way moves the other)"
    if name == "secondary_id" and raw < _SECONDARY_OFF and raw in others:
        return f"secondary_id = {raw} is the ID of a servo on the bus: two servos would answer as one"
    return ""


def check(model: Model, new: Mapping[str, int], now: Mapping[str, int], who: str, force: bool, dxl_id: int,
          other_ids: Iterable[int] = ()) -> None:
    """BadArguments (one line: the first problem, and how many there are) when ``new`` has a problem
    ``force`` does not allow; nothing is sent either way."""
    found = [p for p in problems(model, new, now, dxl_id, other_ids) if not (force and p.forcible)]
    if not found:
        return
    first = found[0]
    more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
    advice = "; --force writes it anyway" if first.forcible else ""
    raise BadArguments(f"{who}: {first.text}: refused, nothing written{advice}{more}")
