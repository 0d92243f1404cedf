"""The ``joints`` block of the parameters: the robot's joints as the URDF describes them.

    joints:
      shoulder: {id: 1, reduction: 2.0, offset: 0.1, direction: -1,
                 limits: {position: [-1.5, 1.5], velocity: 2.0, effort: 1.2}}
      gripper:  {id: 5, type: prismatic, stroke: [0.0, 0.04], servo_deg: [0.0, 100.0]}
      finger:   {mimic: gripper, multiplier: 1.0, offset: 0.0}   # state only

A parameters file gives it as a map; ROS hands it over flattened (``joints.shoulder.id``,
``joints.shoulder.limits.position``), which is what is read here. ``reduction``: servo turns per
joint turn; ``offset``: the joint's position [rad] when the servo reads 0; ``direction``: +1 or -1;
``type: prismatic``: a linear map from ``servo_deg`` (two servo angles) to ``stroke`` (the joint's
two positions in m); ``limits``: the joint's soft limits in its units (rad or m, rad/s or m/s;
``effort`` in ``joint_state.effort_unit``: A or N·m). A mimic joint is published in ``joint_states`` only.
``ids`` (with ``directions``): a joint driven by two or more servos together, written in one sync
write, its state their mean; beyond ``disagreement_deg`` apart each servo is held where it is
(one line a second while it lasts). ``coupled`` with ``row``: a coupled set (a differential),
``joint = offset + row · the set's servo angles`` [rad], as many joints as servos naming the same
set. Every problem is a ``ConfigError`` of one line naming the parameter. ROS-free.
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..logs import cut
from .mapping import DEG, Coupling, Joint, JointMap, Mimic

PREFIX = "joints."
#: every key of an entry: (type, default, which joints take it, meaning); docs/parameters.md prints it
KEYS: dict[str, tuple[str, str, str, str]] = {
    "id": ("int", "-", "revolute, prismatic", "the servo that drives the joint (0..252; one joint per servo)"),
    "type": ("str", "revolute", "revolute, prismatic", "revolute (rad) or prismatic (m)"),
    "reduction": ("float", "1.0", "revolute", "servo turns per joint turn (above 0)"),
    "direction": ("int", "1", "revolute", "1: the joint turns with the servo, -1: against it"),
    "offset": ("float", "0.0", "revolute, coupled, mimic",
               "revolute, coupled: the joint's position [rad] when the servo(s) read 0 deg; mimic: added to "
               "multiplier x the followed joint"),
    "stroke": ("float[2]", "-", "prismatic", "the joint's positions [m] at the two servo angles of servo_deg"),
    "servo_deg": ("float[2]", "-", "prismatic", "two servo angles [deg] (different), where the joint is at stroke"),
    "coupled": ("int[]", "-", "coupled", "the servos of a coupled set (a differential): as many joints as servos "
                "name the same set"),
    "row": ("float[]", "-", "coupled", "joint = offset + row · the set's servo angles [rad], one factor per servo of "
            "coupled (the set's rows must make an invertible matrix)"),
    "limits.position": ("float[2]", "none", "revolute, prismatic, coupled",
                        "soft limits [rad or m]: a command beyond is clamped (one line a second), a trajectory "
                        "point beyond refused"),
    "limits.velocity": ("float", "none", "revolute, prismatic, coupled",
                        "the fastest the joint is driven [rad/s or m/s]: velocity commands cut, the profile of a "
                        "position command capped, a faster trajectory refused"),
    "limits.effort": ("float", "none", "revolute, prismatic", "the largest effort command [A, or N·m (N) with "
                      "joint_state.effort_unit: Nm]"),
    "ids": ("int[]", "-", "paired", "the servos that drive the joint together (two or more, each in one joint)"),
    "directions": ("int[]", "all 1", "paired", "1 or -1 per servo of ids: how each is mounted"),
    "disagreement_deg": ("float", "2.0", "paired",
                         "the largest spread [joint deg] of its servos' positions; beyond, each is held where it "
                         "is, its trajectory ends, one line a second"),
    "mimic": ("str", "-", "mimic", "the joint this one follows (state only: published in joint_states)"),
    "multiplier": ("float", "1.0", "mimic", "mimic position = multiplier x the followed joint's + offset"),
}
#: the keys of a joint driven by one servo, of a mimic joint, and those not handled yet
REVOLUTE_KEYS = frozenset(k for k, v in KEYS.items() if "revolute" in v[2])
PAIRED_KEYS = frozenset(k for k, v in KEYS.items() if "paired" in v[2] or ("revolute" in v[2] and k not in ("id", "type")))
PRISMATIC_KEYS = frozenset(k for k, v in KEYS.items() if "prismatic" in v[2])
MIMIC_KEYS = frozenset(k for k, v in KEYS.items() if "mimic" in v[2])
COUPLED_KEYS = frozenset(k for k, v in KEYS.items() if "coupled" in v[2])


def is_joint_parameter(name: str) -> bool:
    return name.startswith(PREFIX)


def joints_block(values: Mapping[str, Any]) -> tuple[dict[str, Joint], dict[str, Mimic]]:
    """The joints and mimic joints of the flattened ``joints.<name>.<key>`` names in ``values``."""
    entries: dict[str, dict[str, Any]] = {}
    for name, value in values.items():
        if not is_joint_parameter(name):
            continue
        joint, _, key = name[len(PREFIX):].partition(".")
        if not joint or not key:
            raise ConfigError(f"parameter '{cut(name)}': the joints block holds one map per joint, e.g. "
                              "joints.shoulder.id")
        entries.setdefault(joint, {})[key] = value
    joints, mimics = {}, {}
    coupled = {joint: keys for joint, keys in entries.items() if "coupled" in keys}
    for joint, keys in entries.items():
        if "mimic" in keys:
            mimics[joint] = _mimic(joint, keys)
        elif joint not in coupled:
            joints[joint] = _joint(joint, keys)
    joints.update(couplings(coupled))
    return joints, mimics


def merged(simple: JointMap | None, values: Mapping[str, Any]) -> JointMap | None:
    """The ``joint_state.*`` joints (``simple``) and the block's, in that order; one servo per joint,
    one joint per name, every mimic following a joint driven by a servo."""
    joints, mimics = joints_block(values)
    if not joints and not mimics:
        return simple
    given = list(simple.joints) if simple is not None else []
    for joint in joints.values():
        _check_new(given, joint)
        given.append(joint)
    names = {j.name for j in given}
    for name, mimic in mimics.items():
        if name in names:
            raise ConfigError(f"joints.{cut(name)}.mimic: '{cut(name)}' is also a joint driven by a servo")
        if mimic.of not in names:
            known = ", ".join(sorted(names)) or "none"
            raise ConfigError(f"joints.{cut(name)}.mimic = '{cut(mimic.of)}': no such joint driven by a servo "
                              f"(known: {cut(known)})")
    return JointMap(tuple(given), tuple(mimics.values()))


def _check_new(given: list[Joint], joint: Joint) -> None:
    """ConfigError when ``joint``'s name or servo is taken by one of ``given``."""
    if any(j.name == joint.name for j in given):
        raise ConfigError(f"joint '{cut(joint.name)}' is both in joint_state.names and in the joints block: give it once")
    for dxl_id in joint.servo_ids:
        other = next((j.name for j in given if dxl_id in j.servo_ids
                      and (j.coupling is None or j.coupling != joint.coupling)), None)
        if other is not None:
            key = "id" if not joint.partners else "ids"
            shown = dxl_id if not joint.partners else list(joint.servo_ids)
            raise ConfigError(f"joints.{cut(joint.name)}.{key} = {shown}: servo {dxl_id} already drives joint "
                              f"'{cut(other)}': one joint per servo")


# ---------------------------------------------------------------------------- one entry
def _joint(name: str, keys: Mapping[str, Any]) -> Joint:
    where = f"joints.{cut(name)}"
    if "ids" in keys:
        return _paired(name, where, keys)
    kind = keys.get("type", "revolute")
    if kind not in ("revolute", "prismatic"):
        raise ConfigError(f"{where}.type = {cut(repr(kind))}: revolute or prismatic")
    allowed = PRISMATIC_KEYS if kind == "prismatic" else REVOLUTE_KEYS
    unknown = sorted(set(keys) - allowed)
    if unknown:
        raise ConfigError(f"{where}.{cut(unknown[0])}: unknown key for a {kind} joint (known: {', '.join(sorted(allowed))})")
    if "id" not in keys:
        raise ConfigError(f"{where}: no id: give the servo that drives it (id: 1), or mimic: another joint")
    dxl_id = _integer(f"{where}.id", keys["id"])
    if not 0 <= dxl_id <= 252:
        raise ConfigError(f"{where}.id = {dxl_id}: servo IDs are 0..252")
    scale, zero = _prismatic(where, keys) if kind == "prismatic" else _revolute(where, keys)
    return Joint(name, dxl_id, scale, zero, kind == "prismatic", *_limits(where, keys))


def _revolute(where: str, keys: Mapping[str, Any]) -> tuple[float, float]:
    """scale [rad/deg] and zero [rad] of a revolute joint's reduction, direction and offset."""
    reduction = _number(f"{where}.reduction", keys.get("reduction", 1.0))
    if not reduction > 0 or reduction > 1e6:
        raise ConfigError(f"{where}.reduction = {reduction:g}: servo turns per joint turn, above 0 (and at most 1e6)")
    direction = _direction(f"{where}.direction", keys.get("direction", 1))
    return direction * DEG / reduction, _number(f"{where}.offset", keys.get("offset", 0.0))


def _limits(where: str, keys: Mapping[str, Any]) -> tuple[tuple[float, float], float, float]:
    lo, hi = _pair(f"{where}.limits.position", keys.get("limits.position", [-math.inf, math.inf]), ordered=True)
    velocity = _positive(f"{where}.limits.velocity", keys.get("limits.velocity", math.inf))
    effort = _positive(f"{where}.limits.effort", keys.get("limits.effort", math.inf))
    return (lo, hi), velocity, effort


def _paired(name: str, where: str, keys: Mapping[str, Any]) -> Joint:
    """A revolute joint driven by two or more servos together (each with its own direction)."""
    unknown = sorted(set(keys) - PAIRED_KEYS)
    if unknown:
        raise ConfigError(f"{where}.{cut(unknown[0])}: unknown key for a joint of several servos (known: "
                          f"{', '.join(sorted(PAIRED_KEYS))})")
    ids = _servo_ids(f"{where}.ids", keys["ids"])
    directions = _listed(keys.get("directions", [1] * len(ids)))
    if len(directions) != len(ids):
        raise ConfigError(f"{where}.directions: {len(directions)} values for {len(ids)} servos: one per servo of ids")
    signs = [_direction(f"{where}.directions", d) for d in directions]
    scale, zero = _revolute(where, keys)
    spread = _positive(f"{where}.disagreement_deg", keys.get("disagreement_deg", 2.0))
    return Joint(name, ids[0], scale * signs[0], zero, False, *_limits(where, keys),
                 partners=tuple((i, scale * s) for i, s in zip(ids[1:], signs[1:])), disagreement=spread * DEG)


def _servo_ids(where: str, value: Any) -> list[int]:
    """Two or more different servo IDs (``ids``, ``coupled``); ConfigError naming ``where``."""
    ids = [_integer(where, i) for i in _listed(value)]
    if len(ids) < 2 or len(set(ids)) != len(ids) or not all(0 <= i <= 252 for i in ids):
        raise ConfigError(f"{where} = {cut(repr(ids))}: two or more different servo IDs (0..252)")
    return ids


def _listed(value: Any) -> list[Any]:
    """A list parameter's values (a single value: a list of one)."""
    return list(value) if isinstance(value, (list, tuple)) or hasattr(value, "tolist") else [value]


def _direction(where: str, value: Any) -> int:
    direction = _integer(where, value)
    if direction not in (1, -1):
        raise ConfigError(f"{where} = {direction}: 1 or -1")
    return direction


def _prismatic(where: str, keys: Mapping[str, Any]) -> tuple[float, float]:
    """scale [m/deg] and zero [m] of the linear map from ``servo_deg`` to ``stroke``."""
    for key in ("stroke", "servo_deg"):
        if key not in keys:
            raise ConfigError(f"{where}: a prismatic joint needs stroke (its two positions [m]) and servo_deg (the "
                              "servo's angles there [deg])")
    s0, s1 = _pair(f"{where}.stroke", keys["stroke"])
    d0, d1 = _pair(f"{where}.servo_deg", keys["servo_deg"])
    if s0 == s1 or d0 == d1:
        raise ConfigError(f"{where}: stroke {[s0, s1]} and servo_deg {[d0, d1]} need two different values each")
    scale = (s1 - s0) / (d1 - d0)
    return scale, s0 - scale * d0


#: one joint of a coupled set as its entry gives it: name, {servo ID: factor}, offset, limits
_Member = tuple[str, dict[int, float], float, tuple[tuple[float, float], float, float]]


def couplings(entries: Mapping[str, Mapping[str, Any]]) -> dict[str, Joint]:
    """The joints of coupled sets: the entries naming the same servos (in any order) make one set,
    as many joints as servos, rows that make an invertible matrix."""
    sets: dict[tuple[int, ...], list[_Member]] = {}
    for name, keys in entries.items():
        ids, member = _member(name, keys)
        sets.setdefault(tuple(sorted(ids)), []).append(member)
    out: dict[str, Joint] = {}
    for servo_ids, members in sets.items():
        out.update(_coupled_set(servo_ids, members))
    return out


def _member(name: str, keys: Mapping[str, Any]) -> tuple[list[int], _Member]:
    where = f"joints.{cut(name)}"
    unknown = sorted(set(keys) - COUPLED_KEYS)
    if unknown:
        raise ConfigError(f"{where}.{cut(unknown[0])}: unknown key for a joint of a coupled set (known: "
                          f"{', '.join(sorted(COUPLED_KEYS))})")
    ids = _servo_ids(f"{where}.coupled", keys["coupled"])
    row = [_number(f"{where}.row", v) for v in _listed(keys.get("row", []))]
    if len(row) != len(ids):
        raise ConfigError(f"{where}.row: {len(row)} factors for {len(ids)} servos: one per servo of coupled")
    offset = _number(f"{where}.offset", keys.get("offset", 0.0))
    return ids, (name, dict(zip(ids, row)), offset, _limits(where, keys))


def _coupled_set(servo_ids: tuple[int, ...], members: list[_Member]) -> dict[str, Joint]:
    names = [m[0] for m in members]
    if len(members) != len(servo_ids):
        raise ConfigError(f"joints.{cut(names[0])}.coupled = {list(servo_ids)}: {len(servo_ids)} servos need "
                          f"{len(servo_ids)} joints naming them, {len(members)} do ({', '.join(cut(n) for n in names)})")
    rows = tuple(tuple(factors[i] for i in servo_ids) for _, factors, _, _ in members)
    if abs(float(np.linalg.det(np.asarray(rows)))) < 1e-9:
        raise ConfigError(f"joints {', '.join(cut(n) for n in names)}: their rows {[list(r) for r in rows]} cannot "
                          "be inverted: no servo angles for a joint command")
    coupling = Coupling(servo_ids, tuple(names), rows, tuple(m[2] for m in members))
    out = {}
    for (name, _, offset, limits), factors_row in zip(members, rows):
        scales = [f * DEG for f in factors_row]
        out[name] = Joint(name, servo_ids[0], scales[0], offset, False, *limits,
                          partners=tuple(zip(servo_ids[1:], scales[1:])), coupling=coupling)
    return out


def _mimic(name: str, keys: Mapping[str, Any]) -> Mimic:
    where = f"joints.{cut(name)}"
    unknown = sorted(set(keys) - MIMIC_KEYS)
    if unknown:
        raise ConfigError(f"{where}.{cut(unknown[0])}: unknown key for a mimic joint (known: {', '.join(sorted(MIMIC_KEYS))})")
    of = keys["mimic"]
    if not isinstance(of, str) or not of.strip():
        raise ConfigError(f"{where}.mimic = {cut(repr(of))}: the name of the joint it follows")
    return Mimic(name, of, _number(f"{where}.multiplier", keys.get("multiplier", 1.0)),
                 _number(f"{where}.offset", keys.get("offset", 0.0)))


# ---------------------------------------------------------------------------- values
def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where} = {cut(repr(value))}: a finite number")
    if abs(value) > 1e9:
        raise ConfigError(f"{where} = {value:g}: out of range (at most 1e9)")
    return float(value)


def _integer(where: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where} = {cut(repr(value))}: a whole number")
    return value


def _positive(where: str, value: Any) -> float:
    if value == math.inf:
        return math.inf
    number = _number(where, value)
    if not number > 0:
        raise ConfigError(f"{where} = {number:g}: above 0")
    return number


def _pair(where: str, value: Any, ordered: bool = False) -> tuple[float, float]:
    items = list(value) if isinstance(value, (list, tuple)) or hasattr(value, "tolist") else None
    if items is None or len(items) != 2:
        raise ConfigError(f"{where} = {cut(repr(value))}: two numbers, e.g. [-1.5, 1.5]")
    if ordered and all(v in (-math.inf, math.inf) for v in items):
        return -math.inf, math.inf
    lo, hi = (_number(where, v) for v in items)
    if ordered and not lo < hi:
        raise ConfigError(f"{where} = [{lo:g}, {hi:g}]: the lower limit first, below the upper one")
    return lo, hi


__all__ = ["COUPLED_KEYS", "KEYS", "MIMIC_KEYS", "PAIRED_KEYS", "PREFIX", "PRISMATIC_KEYS", "REVOLUTE_KEYS", "couplings",
           "is_joint_parameter", "joints_block", "merged"]
