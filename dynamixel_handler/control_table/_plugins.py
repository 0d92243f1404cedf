"""Servo families added by installed packages, without editing this one.

A package adds a family by declaring an entry point in the group ``dynamixel_handler.families``
(``[project.entry-points."dynamixel_handler.families"]`` of its ``pyproject.toml``, or
``entry_points={...}`` of its ``setup.py``) that names a ``FamilyPlugin``: the family's
``ServoFamily`` value (its data and its behaviour object) and a function that builds its models.
``control_table`` reads the group once, when it is first imported, and builds its tables from what
it finds: ``FAMILIES`` (or ``PROTOCOL1_FAMILIES``), ``family_named``, ``model_by_number`` and the
parameters ``init/used_servo_series.<title>`` then know the family in every process that has the
package installed (the node, the set-up tool, the simulator), as they know a built-in one.

A plug-in that cannot be loaded, is malformed, or whose name, title, suffix or model numbers are a
built-in family's (or an earlier plug-in's) is ignored, with one log line saying why
(``dynamixel_handler.control_table``); the built-in families are never replaced.
"""
from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import AbstractSet, Callable, Dict, Iterable, List, Mapping, Set, Tuple

from ._family import ServoFamily
from ._model import OPERATING_MODES, Model
from .behaviour import X_BITS, FamilyBehaviour

#: the entry-point group a package declares its families in
GROUP = "dynamixel_handler.families"
#: a built-in model by its number and protocol (``built_in(1020)``, ``built_in(12, protocol=1)``): what
#: a plug-in's table may be derived from
BuiltIn = Callable[..., Model]
#: a plug-in family with its models
Added = Tuple[ServoFamily, Tuple[Model, ...]]

_log = logging.getLogger("dynamixel_handler.control_table")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


@dataclass(frozen=True)
class FamilyPlugin:
    """What an entry point of ``GROUP`` names: a family and how its models are built.

    ``models`` is called once, when ``control_table`` is imported, with ``BuiltIn``; it returns the
    family's models (``Model`` values whose ``family`` is ``family``; ``dataclasses.replace`` of a
    built-in model gives a table derived from one)."""

    family: ServoFamily
    models: Callable[[BuiltIn], Iterable[Model]]


class Refused(ValueError):
    """Why a plug-in family is not taken."""


def installed(families: Iterable[ServoFamily], numbers: Mapping[int, AbstractSet[int]],
              built_in: BuiltIn) -> Tuple[Added, ...]:
    """The families the installed entry points of ``GROUP`` add (by entry-point name), each with its
    models; ``families`` and ``numbers`` (model numbers by protocol) are the ones already taken."""
    known: List[ServoFamily] = list(families)
    taken: Dict[int, Set[int]] = {protocol: set(n) for protocol, n in numbers.items()}
    added: List[Added] = []
    for point in sorted(entry_points(group=GROUP), key=lambda p: (p.name, p.value)):
        try:
            family, models = _take(point, known, taken, built_in)
        except Exception as exc:  # another package's code: whatever it raises, the built-in families go on
            _log.warning("servo family plug-in %r (%s) ignored: %s", point.name, point.value, exc)
            continue
        known.append(family)
        taken.setdefault(family.protocol, set()).update(m.number for m in models)
        added.append((family, models))
    return tuple(added)


def _take(point: EntryPoint, known: List[ServoFamily], taken: Mapping[int, AbstractSet[int]],
          built_in: BuiltIn) -> Added:
    plugin = point.load()
    if not isinstance(plugin, FamilyPlugin):
        raise Refused(f"it names a {type(plugin).__name__}, not a FamilyPlugin")
    family = plugin.family
    check_family(family, known)
    models = tuple(plugin.models(built_in))
    check_models(family, models, taken.get(family.protocol, frozenset()))
    return family, models


def check_family(family: object, known: Iterable[ServoFamily]) -> None:
    """Refused (why) unless ``family`` is a well-formed family that clashes with none of ``known``."""
    if not isinstance(family, ServoFamily):
        raise Refused(f"its family is a {type(family).__name__}, not a ServoFamily")
    if not isinstance(family.behaviour, FamilyBehaviour):
        raise Refused(f"family {family.name}: its behaviour is a {type(family.behaviour).__name__}, "
                      "not a FamilyBehaviour")
    for what in ("name", "title", "suffix"):
        _check_name(family, what, known)
    if family.protocol not in (1, 2):
        raise Refused(f"family {family.name}: protocol {family.protocol!r} is neither 1 nor 2")
    if not family.modes or not family.modes <= set(OPERATING_MODES):
        raise Refused(f"family {family.name}: modes {sorted(family.modes)} are not among {sorted(OPERATING_MODES)}")
    unknown = [cause for cause, _ in family.behaviour.error_bits if cause not in X_BITS]
    if unknown:
        raise Refused(f"family {family.name}: error bits {unknown} are none of {sorted(X_BITS)}")
    if family.command_family is not None and family.command_family not in known:
        raise Refused(f"family {family.name}: command topics of its own need messages of their own; set "
                      "series_topics=False or commanded_as a built-in family")


def _check_name(family: ServoFamily, what: str, known: Iterable[ServoFamily]) -> None:
    """Its ``what`` (name, title, suffix) is a name no known family has, in any case."""
    value = getattr(family, what)
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise Refused(f"family {family.name}: its {what} {value!r} is not a name (a letter, then letters, digits, _)")
    clash = next((f for f in known if getattr(f, what).lower() == value.lower()), None)
    if clash is not None:
        raise Refused(f"family {family.name}: its {what} {value!r} is the {what} of family {clash.name}")


def check_models(family: ServoFamily, models: Tuple[Model, ...], taken: AbstractSet[int]) -> None:
    """Refused (why) unless ``models`` are models of ``family`` whose numbers none of ``taken`` has."""
    if not models:
        raise Refused(f"family {family.name}: no models")
    stray = [m for m in models if not isinstance(m, Model) or m.family is not family]
    if stray:
        raise Refused(f"family {family.name}: {getattr(stray[0], 'name', type(stray[0]).__name__)} is not a Model "
                      "of the family")
    numbers = [m.number for m in models]
    clash = sorted(set(numbers) & set(taken)) or sorted({n for n in numbers if numbers.count(n) > 1})
    if clash:
        raise Refused(f"family {family.name}: model number {clash[0]} is taken")
    if family.dummy_model not in numbers:
        raise Refused(f"family {family.name}: its dummy_model {family.dummy_model} is none of its models")
