"""A servo's entry of the ``servos`` block against its model: what it refuses, and the register
values it asks for (ROS-free).

``refusals`` lists, one line each naming servo, item and value, the items the model lacks, the
values beyond its e-Manual range (``Model.value_range``; the position limits: the model's
position range) and a mode it lacks; ``dangers`` runs the set-up tool's checks on what the entry
would change (min below max; a protection lowered only with ``force: true``). ``register_values`` turns an entry into register values
(pulses); a bit-field register (Drive Mode, Shutdown, the XL-320's LED colour) takes the bits
the entry gives and keeps the others of the value the servo holds.
"""
from __future__ import annotations

from typing import Any, Callable, Iterable

from . import units
from .control_table import POSITION_MODES, Model
from .servo import error_state
from .servo.settings import BITS, FIELDS, FORCE, LED, MODE, PULSE, UNIT, WATCHDOG, ServoSetting
from .setup_tool.checks import needed, problems

#: modes that need a current sensor (as ``commands.tables.CURRENT_MODES``)
CURRENT_MODES = frozenset({"current", "cur_position"})

#: (control-table item) -> the value the servo holds now (None: unknown)
Current = Callable[[str], "int | None"]


def led_item(model: Model, colour: str) -> str | None:
    """The register an LED colour is written to: P/PRO ``led_<colour>``, X ``led`` (red), XL-320
    ``led_colour``; None if the model has no LED of that colour."""
    if model.has(f"led_{colour}"):
        return f"led_{colour}"
    if colour == "red" and model.has("led"):
        return "led"
    return "led_colour" if model.has("led_colour") else None


def _item_of(model: Model, field: str, mode: Any = None) -> str | None:
    """The register a field is written to on this model (None: it has none). ``mode``: the
    entry's mode, which decides where the speed of a move goes on a model without Profile
    Velocity whose Moving Speed is it in Joint Mode (Protocol 1.0, XL-320): there in a position
    mode, nowhere else (in Wheel Mode it is the velocity goal: it would turn)."""
    spec = FIELDS[field]
    if spec.kind == LED:
        return led_item(model, field.split(".")[1].split("_")[0])
    if spec.kind == MODE:
        return spec.item if model.has(spec.item) or model.mode_select is not None else None
    behaviour = model.family.behaviour
    if spec.item == "profile_velocity" and behaviour.speed_in_position_only(model):
        return behaviour.speed_item(model) if mode in POSITION_MODES else None
    return spec.item if model.has(spec.item) else None


def value_range(model: Model, item: str) -> tuple[int, int]:
    """The raw values the e-Manual allows (the position limits: the model's position range)."""
    if item in ("max_position_limit", "min_position_limit") and model.position_max_pulse > model.position_min_pulse:
        return model.position_min_pulse, model.position_max_pulse
    return model.value_range(item)


def refusals(model: Model, setting: ServoSetting) -> list[str]:
    """Why the model refuses items of the entry: one line each (empty: it takes them all)."""
    return list(refused_fields(model, setting).values())


def refused_fields(model: Model, setting: ServoSetting) -> dict[str, str]:
    """{field: why} of the entry's items the model refuses, in the entry's order."""
    out = {}
    for field, value in setting.values.items():
        where = f"servos.{setting.name}.{field} = {value}"
        item = _item_of(model, field, setting.values.get("mode"))
        if item is None:
            out[field] = f"{where}: ID {setting.dxl_id} ({model.name}) has no {FIELDS[field].item}" + _speed_hint(model, field)
            continue
        why = _refused(model, field, item, value)
        if why:
            out[field] = f"{where}: ID {setting.dxl_id} ({model.name}) {why}"
    return out


def _refused(model: Model, field: str, item: str, value: Any) -> str:
    kind = FIELDS[field].kind
    if kind == MODE:
        if value in CURRENT_MODES and not (model.has("current_limit") or model.has("goal_current")):  # the reason first
            return f"has no current sensor, so no '{value}' mode"
        if value not in model.modes or value not in model.mode_values:
            return f"has no '{value}' mode (its modes: {', '.join(sorted(set(model.modes) & set(model.mode_values)))})"
        return ""
    if kind not in (UNIT, PULSE, WATCHDOG):
        return ""
    lo, hi = value_range(model, item)
    pulses = to_pulses(model, field, value)
    if lo <= pulses <= hi and (kind == PULSE or _exact(model, item, value, pulses)):
        return ""
    if kind == PULSE:
        return f"is outside its e-Manual range {lo}..{hi}"
    shown = units.pulse_to_unit([model, model], item, [lo, hi])
    return f"is outside its e-Manual range {float(shown[0]):g}..{float(shown[1]):g}"


def _exact(model: Model, item: str, value: float, pulses: int) -> bool:
    """The pulses stand for the value (not clipped to the register's bytes by the conversion)."""
    back, step = units.pulse_to_unit([model, model], item, [pulses, pulses + 1])
    return abs(float(back) - value) <= abs(float(step) - float(back))


def to_pulses(model: Model, field: str, value: Any) -> int:
    """A number of the entry in the register's units."""
    spec = FIELDS[field]
    if spec.kind == PULSE:
        return int(value)
    item = _item_of(model, field, "position") or spec.item
    pulses = int(units.unit_to_pulse([model], item, [float(value)])[0])
    if spec.kind == WATCHDOG and value > 0:
        pulses = max(1, pulses)  # a time under one register unit is one unit, not off
    if item != spec.item and pulses == 0:
        pulses = 1  # Moving Speed 0 in Joint Mode is full speed: the slowest instead
    return pulses


def _speed_hint(model: Model, field: str) -> str:
    """What to do where the speed of a move is Moving Speed, set in Joint Mode only."""
    if FIELDS[field].item == "profile_velocity" and model.family.behaviour.speed_in_position_only(model):
        return (": its speed of a move is Moving Speed, which is also the velocity goal in Wheel Mode; give "
                "'mode: position' (or another position mode) in the entry to set it")
    return ""


def dangers(model: Model, setting: ServoSetting, current: Current,
            others: Iterable[int] = ()) -> tuple[dict[str, str], list[str]]:
    """The set-up tool's checks (``setup_tool.checks.problems``) on the values the entry would
    change: min below max across a limit pair (refused), and what lowers a protection: Shutdown
    bits cleared, a temperature or voltage limit beyond its factory value, the direction reversed
    (refused unless the entry says ``force: true``). ``current``: what the servo holds (read before
    anything is written); ``others``: the other servos' IDs. ({item: why refused}, lines of what
    ``force: true`` lets through)."""
    new = register_values(model, setting, current)
    new.pop("operating_mode", None)
    now = {item: value for item in set(new) | set(needed(model, new)) if (value := current(item)) is not None}
    changed = {item: value for item, value in new.items() if now.get(item) != value}
    refused: dict[str, str] = {}
    forced = []
    for problem in problems(model, changed, now, setting.dxl_id, others):
        where = f"servos.{setting.name}: ID {setting.dxl_id} ({model.name}) {problem.text}"
        if problem.forcible and setting.force:
            forced.append(f"{where}: written ({FORCE}: true)")
            continue
        why = where + (f": give '{FORCE}: true' in the entry to write it anyway" if problem.forcible else "")
        refused[problem.item] = f"{refused[problem.item]}; {why}" if problem.item in refused else why
    return refused, forced


def register_values(model: Model, setting: ServoSetting, current: Current) -> dict[str, int]:
    """{item: register value} the entry asks for (the mode: its register value); bit fields merged
    with the servo's bits (``current``)."""
    out: dict[str, int] = {}
    bits: dict[str, dict[str, Any]] = {}
    for field, value in setting.values.items():
        kind, item = FIELDS[field].kind, _item_of(model, field, setting.values.get("mode"))
        if item is None:
            continue
        if kind == MODE:
            out[item] = model.mode_values[value]
        elif kind in (UNIT, PULSE, WATCHDOG):
            out[item] = to_pulses(model, field, value)
        elif kind in (BITS, LED):
            bits.setdefault(item, {})[field.split(".", 1)[1]] = value
    for item, given in bits.items():
        value = _merged(model, item, given, current(item) or 0)
        if value is not None:
            out[item] = value
    return out


def _merged(model: Model, item: str, given: dict[str, Any], old: int) -> int | None:
    if item == "drive_mode":
        was = units.decode_drive_mode([old])
        value = units.encode_drive_mode(
            reverse_mode=bool(given.get("reverse_mode", was["reverse_mode"][0])),
            profile_configuration=str(given.get("profile_configuration", was["profile_configuration"][0])),
            torque_on_by_goal_update=bool(given.get("torque_on_by_goal_update", was["torque_on_by_goal_update"][0])))
        return value | (old & ~0x0D)
    if item == "shutdown":  # in the X and P bit layout; the XL-320's own order on its register
        flags = {name: bool(on[0]) for name, on in units.decode_shutdown([error_state.common_bits(model, old)]).items()}
        flags.update({name: bool(on) for name, on in given.items()})
        return error_state.own_bits(model, units.encode_shutdown(**flags))
    percent = float(next(iter(given.values())))
    if item == "led_colour":  # one bit per colour (0 red, 1 green, 2 blue), on from 50 %
        value = old
        for name, pct in given.items():
            bit = 1 << ("red", "green", "blue").index(name.split("_")[0])
            value = value | bit if pct >= 50.0 else value & ~bit
        return value
    if item == "led":  # X: one LED, on from 50 %
        return 1 if percent >= 50.0 else 0
    return int(percent * 255.0 / 100.0 + 0.5)  # P, PRO: 0..255


__all__ = ["dangers", "led_item", "refusals", "refused_fields", "register_values", "to_pulses", "value_range"]
