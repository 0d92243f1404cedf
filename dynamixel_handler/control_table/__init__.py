"""Control-table facts for every Dynamixel the handler drives (Protocol 2.0: X, P, PRO, Y, XL-320;
Protocol 1.0: AX, RX, DX, EX, MX): addresses, sizes, signs, EEPROM flags and unit scales, by
canonical snake_case item name, and each model's family (``_family.py``).

Addresses and sizes of X, P and PRO "-R(A)" models come from the control-table files shipped in
the ``dynamixel-sdk`` wheel; the old PRO "-R" table, unit scales and the items those files omit
are ours (``_facts.py``), taken from the ROBOTIS e-Manual, and so are the factory values of each model
(``_factory.py``) and the values each of its registers may take (``_ranges.py``,
``Model.value_range``). Nothing here talks to hardware.

An item keeps its canonical name even where a series calls it differently: old PRO "Goal Torque"
is ``goal_current``, "Torque Limit" is ``current_limit`` and "Goal Acceleration" is
``profile_acceleration``.
"""

from __future__ import annotations

import functools
import math
from types import MappingProxyType
from typing import Any, Callable, Dict, List, Mapping, Tuple

from . import _plugins, _protocol1, _xl320, _y
from ._factory import FACTORY
from ._facts import (
    BAUD_RATES,
    EEPROM_END,
    INDIRECT,
    MODEL_FACTS,
    OLD_PRO_ITEMS,
    OPERATING_MODES_OF,
    SIGNED_ITEMS,
    TABLE_SIZE,
    ModelFacts,
)
from ._family import BUILT_IN, BUILT_IN_NAMED, BUILT_IN_PROTOCOL1, MAX_ROTATION, PRO, P, ServoFamily, X
from ._item import Item
from ._model import OPERATING_MODES, Model
from ._modes import KEPT_POSITION_MODES, POSITION_LIMITED_MODES, POSITION_MODES
from ._plugins import FamilyPlugin
from ._ranges import LISTED as RANGED_ITEMS
from ._ranges import ranges_of
from ._sdk_files import load_sdk_table
from ._torque import TORQUE, TorqueFigures, torque_figures

__all__ = ["FAMILIES", "KEPT_POSITION_MODES", "MAX_ROTATION", "OPERATING_MODES", "POSITION_LIMITED_MODES",
           "POSITION_MODES", "PROTOCOL1_FAMILIES", "PRO", "P", "RANGED_ITEMS", "SERIES", "TORQUE", "X", "FamilyPlugin",
           "Item", "Model", "ServoFamily", "TorqueFigures", "family_named", "family_titled", "known_models",
           "model_by_number", "protocol1_model_by_number", "protocol1_models", "torque_figures"]

def _ranges(number: int, items: Mapping[str, Item]) -> Dict[str, Any]:
    """``ranges`` and ``byte_range_items`` of a model: its e-Manual ranges (within its registers'
    bytes), an item's own range where it has one (XL-320), else the byte range of a listed item."""
    manual = ranges_of(number)
    ranges: Dict[str, Tuple[int, int]] = {}
    kept = set()
    for name, item in items.items():
        if name in manual:
            lo, hi = manual[name]
            ranges[name] = (max(lo, item.min_raw), min(hi, item.max_raw))
        elif item.value_range is not None:
            ranges[name] = item.value_range
        elif name in RANGED_ITEMS:
            ranges[name] = (item.min_raw, item.max_raw)
            kept.add(name)
    return {"ranges": MappingProxyType(ranges), "byte_range_items": frozenset(kept)}


def _raw_items(facts: ModelFacts) -> Tuple[Dict[str, Tuple[int, int]], Dict[str, float]]:
    if facts.old_pro:
        rows, type_info = dict(OLD_PRO_ITEMS), {}
    else:
        table = load_sdk_table(facts.sdk_file)
        rows, type_info = dict(table.rows), table.type_info
    rows.update(facts.extra_items)
    for name in facts.missing_items:
        del rows[name]
    return rows, type_info


def _layout(facts: ModelFacts) -> str:
    if facts.old_pro:
        return "OLD_PRO"
    if facts.series == "X" and facts.current_ma == 1.0:  # X330 and XM335: 1 mA per LSB
        return "X330"
    return facts.series


def _build(number: int, facts: ModelFacts) -> Model:
    rows, _type_info = _raw_items(facts)
    layout = _layout(facts)
    eeprom_end = EEPROM_END[layout]
    items = {
        name: Item(name, address, size, name in SIGNED_ITEMS, address < eeprom_end)
        for name, (address, size) in sorted(rows.items(), key=lambda kv: kv[1][0])
    }
    family = BUILT_IN_NAMED[facts.series]
    if family.x_table:
        position_scale = 360.0 / 4096.0
        zero, pmin, pmax = 2048, 0, 4095
    else:
        position_scale = 180.0 / facts.half_turn_pulses
        zero, pmin, pmax = 0, -facts.half_turn_pulses, facts.half_turn_pulses
    if facts.position_range is not None:
        pmin, pmax = facts.position_range
    ports = tuple(n for n in (1, 2, 3, 4) if f"external_port_data_{n}" in items)
    indirect_key = "XM335" if facts.name.startswith(("XM335", "XC335")) else layout
    modes = facts.modes or OPERATING_MODES_OF[layout]
    blocks, targets = INDIRECT[indirect_key]
    return Model(
        number=number,
        name=facts.name,
        family=family,
        items=MappingProxyType(items),
        position_deg_per_pulse=position_scale,
        position_zero_pulse=zero,
        velocity_deg_s_per_pulse=facts.velocity_rpm * 6.0,          # rpm -> deg/s
        acceleration_deg_ss_per_pulse=facts.acceleration_rpm2 / 10.0,  # rev/min^2 -> deg/s^2
        current_ma_per_pulse=facts.current_ma,
        pwm_percent_per_pulse=100.0 / facts.pwm_full_scale,
        position_max_pulse=pmax,
        position_min_pulse=pmin,
        external_ports=ports,
        layout=layout,
        baud_rates=MappingProxyType(dict(BAUD_RATES[layout])),
        operating_modes=modes,
        indirect=blocks,
        indirect_targets=targets,
        table_size=TABLE_SIZE[indirect_key],
        factory=MappingProxyType({k: v for k, v in FACTORY.get(number, {}).items() if k in items}),
        **_ranges(number, items), **_own_modes(facts, modes),
    )


def _own_modes(facts: ModelFacts, modes: Tuple[int, ...]) -> Dict[str, Any]:
    """A model with modes of its own: its mode names and values (the others keep their family's)."""
    if not facts.own_modes:
        return {}
    values = {name: value for name, value in OPERATING_MODES.items() if value in modes}
    own: Dict[str, Any] = {"own_modes": True, "mode_values": MappingProxyType(values)}
    if facts.position_range is not None:  # a stroke, not turns: no goal beyond its limits
        own["position_limited_modes"] = POSITION_LIMITED_MODES + ("cur_position",)
    return own


def _build_y(number: int) -> Model:
    """A DYNAMIXEL-Y model from its SDK file and the facts of ``_y``."""
    name, sdk_file = _y.SDK_FILES[number]
    rows = _y.rows(load_sdk_table(sdk_file).rows)
    items = {n: Item(n, address, size, signed, eeprom)
             for n, (address, size, signed, eeprom) in sorted(rows.items(), key=lambda kv: kv[1][0])}
    return Model(
        number=number, name=name, family=BUILT_IN_NAMED["Y"], items=MappingProxyType(items),
        position_deg_per_pulse=180.0 / _y.HALF_TURN, position_zero_pulse=0,
        velocity_deg_s_per_pulse=_y.VELOCITY_RPM * 6.0, acceleration_deg_ss_per_pulse=_y.ACCELERATION_RPM2 / 10.0,
        current_ma_per_pulse=_y.CURRENT_MA, pwm_percent_per_pulse=100.0 / _y.PWM_FULL_SCALE,
        position_max_pulse=_y.HALF_TURN, position_min_pulse=-_y.HALF_TURN, layout="Y",
        baud_rates=MappingProxyType(dict(_y.BAUD_RATES)), operating_modes=_y.OPERATING_MODES,
        indirect=_y.INDIRECT, indirect_targets=_y.INDIRECT_TARGETS, table_size=_y.TABLE_SIZE,
        factory=MappingProxyType({k: v for k, v in _y.FACTORY[number].items() if k in items}),
        mode_values=MappingProxyType({m: v for m, v in OPERATING_MODES.items() if v in _y.OPERATING_MODES}),
        item_scales=MappingProxyType(dict(_y.ITEM_SCALES)), hybrid_items=_y.HYBRID, **_ranges(number, items),
    )


def _build_xl320() -> Model:
    """The XL-320 from its SDK file and the facts of ``_xl320`` (a table and modes of its own)."""
    rows = _xl320.rows(load_sdk_table(_xl320.SDK_FILE).rows)
    items = {n: Item(n, address, size, False, address < _xl320.EEPROM_END, bit, span)
             for n, (address, size, bit, span) in sorted(rows.items(), key=lambda kv: kv[1][0])}
    return Model(
        number=_xl320.NUMBER, name=_xl320.NAME, family=BUILT_IN_NAMED["XL320"], items=MappingProxyType(items),
        position_deg_per_pulse=_xl320.POSITION_DEG_PER_PULSE, position_zero_pulse=_xl320.POSITION_ZERO_PULSE,
        velocity_deg_s_per_pulse=_xl320.VELOCITY_RPM * 6.0, pwm_percent_per_pulse=100.0 / _xl320.OUTPUT_FULL_SCALE,
        position_max_pulse=1023, position_min_pulse=0, layout="XL320",
        baud_rates=MappingProxyType(dict(_xl320.BAUD_RATES)), operating_modes=tuple(sorted(_xl320.MODE_VALUES.values())),
        table_size=_xl320.TABLE_SIZE, factory=MappingProxyType(dict(_xl320.FACTORY)),
        mode_values=MappingProxyType(dict(_xl320.MODE_VALUES)), ram_copies=MappingProxyType(dict(_xl320.RAM_COPIES)),
        **_ranges(_xl320.NUMBER, items),
    )


@functools.lru_cache(maxsize=None)
def _built_in_registry() -> Mapping[int, Model]:
    return MappingProxyType({number: build() for number, build in sorted(_BUILDERS.items())})


def _build_protocol1(number: int, spec: _protocol1.Spec) -> Model:
    """A Protocol 1.0 model from the facts of ``_protocol1`` (a table, units and modes of its own)."""
    items = {name: Item(name, address, size, signed, eeprom, bit)
             for name, address, size, eeprom, _, bit, signed in sorted(spec.rows, key=lambda r: r[1])}
    modes = {m: _protocol1.MODE_CODES[m] for m in spec.modes}
    spans = _protocol1.ranges(spec)
    return Model(
        number=number, name=spec.name, family=BUILT_IN_NAMED[spec.family], items=MappingProxyType(items),
        position_deg_per_pulse=spec.deg_per_pulse, position_zero_pulse=spec.zero,
        velocity_deg_s_per_pulse=spec.rpm * 6.0,
        acceleration_deg_ss_per_pulse=_protocol1.ACCELERATION_DEG_SS if "profile_acceleration" in items else math.nan,
        current_ma_per_pulse=spec.current_ma if spec.current_ma is not None else math.nan,
        pwm_percent_per_pulse=100.0 / _protocol1.OUTPUT_FULL_SCALE,
        position_max_pulse=spec.top, position_min_pulse=0, layout=f"P1_{spec.family}",
        baud_rates=MappingProxyType(dict(spec.bauds)), operating_modes=tuple(sorted(modes.values())),
        table_size=max(address + size for _, address, size, *_ in spec.rows),
        factory=MappingProxyType({k: v for k, v in spec.factory.items() if k in items}),
        ranges=MappingProxyType(spans), mode_values=MappingProxyType(modes), own_modes=True,
        ram_copies=MappingProxyType(dict(_protocol1.RAM_COPIES)),
        read_only=frozenset(r[0] for r in spec.rows if r[4]),
        item_zero=MappingProxyType({"present_current": spec.current_zero} if "present_current" in items else {}),
    )


@functools.lru_cache(maxsize=None)
def _built_in_protocol1() -> Mapping[int, Model]:
    return MappingProxyType({number: build() for number, build in sorted(_PROTOCOL1_BUILDERS.items())})


#: every built-in model number, Protocol 2.0 and 1.0 -> how its model is built (when first asked)
_BUILDERS: Mapping[int, Callable[[], Model]] = {
    **{number: functools.partial(_build, number, facts) for number, facts in MODEL_FACTS.items()},
    **{number: functools.partial(_build_y, number) for number in _y.SDK_FILES}, _xl320.NUMBER: _build_xl320}
_PROTOCOL1_BUILDERS: Mapping[int, Callable[[], Model]] = {
    number: functools.partial(_build_protocol1, number, spec) for number, spec in _protocol1.SPECS.items()}


def _built_in_model(number: int, protocol: int = 2) -> Model:
    """A built-in model by its number and protocol (what a plug-in's table may be derived from)."""
    return (_built_in_protocol1() if protocol == 1 else _built_in_registry())[int(number)]


# ------------------------------------------------------------ the tables, with the installed plug-ins
#: the families installed packages add (``_plugins``, entry-point group ``dynamixel_handler.families``)
_ADDED = _plugins.installed(
    BUILT_IN + BUILT_IN_PROTOCOL1,
    {2: set(_BUILDERS), 1: set(_PROTOCOL1_BUILDERS)}, _built_in_model)
_ADDED_MODELS = {protocol: {m.number: m for f, models in _ADDED if f.protocol == protocol for m in models}
                 for protocol in (1, 2)}
#: every Protocol 2.0 family, in the order parameters, topics and logs list them: the built-in ones,
#: then those of installed plug-ins
FAMILIES: Tuple[ServoFamily, ...] = BUILT_IN + tuple(f for f, _ in _ADDED if f.protocol == 2)
#: the Protocol 1.0 families: known by name (``family_named``) and to ``protocol1_models()``, kept out
#: of ``FAMILIES`` (whose models the Protocol 2.0 scan looks up); ``config.USED_FAMILIES`` gives them
#: their ``init/used_servo_series`` keys, and the node drives them
PROTOCOL1_FAMILIES: Tuple[ServoFamily, ...] = BUILT_IN_PROTOCOL1 + tuple(f for f, _ in _ADDED if f.protocol == 1)
SERIES: Tuple[str, ...] = tuple(f.name for f in FAMILIES)
_BY_NAME: Mapping[str, ServoFamily] = {f.name: f for f in FAMILIES + PROTOCOL1_FAMILIES}
_BY_TITLE: Mapping[str, ServoFamily] = {f.title.lower(): f for f in FAMILIES}


def family_named(name: "str | ServoFamily") -> ServoFamily:
    """The family by its name ("X", "P", "PRO"); a family is returned as is. KeyError if unknown."""
    if isinstance(name, ServoFamily):
        return name
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"unknown servo series {name!r} (known: {', '.join(_BY_NAME)})") from None


def family_titled(title: str) -> "ServoFamily | None":
    """The family a parameter value names ("x", "P", "Pro", any case); None if none is."""
    return _BY_TITLE.get(title.strip().lower())


@functools.lru_cache(maxsize=None)
def _registry() -> Mapping[int, Model]:
    return MappingProxyType(dict(sorted({**_built_in_registry(), **_ADDED_MODELS[2]}.items())))


@functools.lru_cache(maxsize=None)
def _protocol1_registry() -> Mapping[int, Model]:
    return MappingProxyType(dict(sorted({**_built_in_protocol1(), **_ADDED_MODELS[1]}.items())))


def protocol1_models() -> List[Model]:
    """Every Protocol 1.0 model (AX, RX, DX, EX, MX with the 1.0 firmware), by model number. Kept
    apart from ``known_models()``: a 1.0 model number is looked up only for a servo that answered in
    Protocol 1.0."""
    return list(_protocol1_registry().values())


def protocol1_model_by_number(number: int) -> Model:
    """The Protocol 1.0 model whose Model Number reads ``number``; KeyError if we do not know it."""
    try:
        return _protocol1_registry()[int(number)]
    except KeyError:
        raise KeyError(f"unknown Protocol 1.0 Dynamixel model number {number}") from None


def model_by_number(number: int, protocol: int = 2) -> Model:
    """The model whose Model Number register reads ``number`` in ``protocol``; KeyError if unknown."""
    if protocol == 1:
        return protocol1_model_by_number(number)
    try:
        return _registry()[int(number)]
    except KeyError:
        raise KeyError(f"unknown Dynamixel model number {number}") from None


def known_models() -> List[Model]:
    """Every supported model, by model number."""
    return list(_registry().values())
