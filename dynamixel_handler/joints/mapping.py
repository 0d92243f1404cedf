"""Joint names on top of servo IDs: the mapping, its validation, and the servo <-> joint conversion.

Robot software (robot_state_publisher, rviz, MoveIt) speaks of joints by name in SI units, while
the handler speaks of servo IDs in degrees. The ``joint_state.*`` parameters map one to the other:

    joint angle [deg] = direction * (servo angle [deg] - offset_deg)

so ``offset_deg`` is what the servo reads when the joint is at its zero, and ``direction = -1``
flips a servo mounted the other way round. Velocity and effort follow the direction (effort is
the present current in A, the only torque-like quantity every model measures). The ``joints``
block (``block.py``) describes more: a reduction, an offset in joint units, a prismatic joint
(a gripper in metres), soft limits, mimic joints; every joint is a ``Joint``, a linear map of its
servo's angle. ROS-free.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ..control_table import Model, torque_figures
from ..errors import ConfigError
from ..logs import cut, some_ids
from ..servo.table import ServoTable

DEG = math.pi / 180.0
#: ``joint_state.effort_unit`` (lower case) -> the unit's name
EFFORT_UNITS = {"a": "A", "nm": "Nm"}


@dataclass(frozen=True)
class Coupling:
    """Servos that drive a set of joints together (a differential): with ``s`` the servos' angles
    [rad] and one row per joint,

        joints = offsets + rows · s,      s = rows⁻¹ · (joints − offsets)

    so a command of any joint of the set writes every servo of it."""

    servo_ids: tuple[int, ...]
    names: tuple[str, ...]                      #: the joints, one per row
    rows: tuple[tuple[float, ...], ...]
    offsets: tuple[float, ...]

    def servos_rad(self, joints: Sequence[float]) -> np.ndarray:
        """The servo angles [rad] that put the joints (in ``names`` order) at ``joints``."""
        rows = np.asarray(self.rows, dtype=np.float64)
        return np.asarray(np.linalg.solve(rows, np.asarray(joints, dtype=np.float64) - np.asarray(self.offsets)))

    def rates(self, joints: Sequence[float]) -> np.ndarray:
        """The servo rates [rad/s] of joint rates (``names`` order)."""
        return np.asarray(np.linalg.solve(np.asarray(self.rows, dtype=np.float64), np.asarray(joints, dtype=np.float64)))


@dataclass(frozen=True)
class Joint:
    """One joint driven by one servo, as a linear map of the servo's angle:

        joint = zero + scale x servo angle [deg]

    in the joint's units (rad, or m for a prismatic joint). ``position_limits`` and
    ``velocity_limit`` are its soft limits in those units (infinite: none)."""

    name: str
    dxl_id: int
    scale: float                 #: joint units per servo degree (the sign is the direction)
    zero: float                  #: the joint's position when the servo reads 0 deg
    prismatic: bool = False
    position_limits: tuple[float, float] = (-math.inf, math.inf)
    velocity_limit: float = math.inf
    effort_limit: float = math.inf   #: in the map's ``effort_unit``
    #: the other servos of a joint driven by several: (ID, scale) each, the same ``zero``
    partners: tuple[tuple[int, float], ...] = ()
    #: the largest spread of a paired joint's servos [joint units] before the joint is held
    disagreement: float = 2.0 * DEG
    #: a joint of a coupled set: ``servos`` are the set's, each scale its row's entry [rad/deg]
    #: (the joint is ``zero`` plus their sum, not their mean)
    coupling: Coupling | None = None

    @property
    def servos(self) -> tuple[tuple[int, float], ...]:
        """(ID, scale) of every servo that drives the joint, the first one first."""
        return ((self.dxl_id, self.scale), *self.partners)

    @property
    def servo_ids(self) -> tuple[int, ...]:
        return tuple(i for i, _ in self.servos)

    def to_servo_deg(self, position: float) -> float:
        """Joint position -> the servo angle [deg] that puts the joint there."""
        return (position - self.zero) / self.scale

    def to_joint(self, servo_deg: float) -> float:
        return self.zero + self.scale * servo_deg

    def clamped(self, position: float) -> float:
        lo, hi = self.position_limits
        return min(max(position, lo), hi)


@dataclass(frozen=True)
class Mimic:
    """A joint that follows another (state only): ``multiplier`` x the other's position + ``offset``."""

    name: str
    of: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class JointMap:
    """The joints driven by servos, in parameter order, and the mimic joints (state only)."""

    joints: tuple[Joint, ...]
    mimics: tuple[Mimic, ...] = ()
    #: the effort's unit: "A" (the present current) or "Nm" (``effort_per_amp``)
    effort_unit: str = "A"

    @classmethod
    def simple(cls, names: Sequence[str], ids: Sequence[int], directions: Sequence[int],
               offsets_deg: Sequence[float]) -> JointMap:
        """The ``joint_state.*`` mapping: joint [rad] = direction x (servo deg - offset_deg) in rad."""
        return cls(tuple(Joint(n, int(i), d * DEG, -d * o * DEG)
                         for n, i, d, o in zip(names, ids, directions, offsets_deg)))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(j.dxl_id for j in self.joints)

    def __len__(self) -> int:
        return len(self.joints)

    def joint(self, name: str) -> Joint:
        """Joint ``name``; KeyError naming the known joints otherwise."""
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"unknown joint '{name}' (known: {', '.join(self.names)})")

    def id_of(self, name: str) -> int:
        """The servo ID of joint ``name``; KeyError naming the known joints otherwise, ValueError
        for a joint driven by several servos (which one is meant?)."""
        joint = self.joint(name)
        if joint.partners:
            ids = " and ".join(str(i) for i in joint.servo_ids)
            raise ValueError(f"joint {name} is driven by servos {ids}: name one of them (id_{joint.dxl_id})")
        return joint.dxl_id

    @property
    def servo_ids(self) -> tuple[int, ...]:
        """Every servo that drives a joint."""
        return tuple(i for j in self.joints for i in j.servo_ids)

    def with_zeros(self, zeros: Mapping[str, float]) -> JointMap:
        """This map with the named joints' zeros (their positions when their servos read 0)
        replaced; a coupled set's offsets with them."""
        if not zeros:
            return self
        sets = {j.coupling: replace(j.coupling, offsets=tuple(zeros.get(n, o) for n, o in zip(j.coupling.names,
                                                                                           j.coupling.offsets)))
                for j in self.joints if j.coupling is not None}
        return replace(self, joints=tuple(replace(j, zero=zeros.get(j.name, j.zero),
                                                  coupling=None if j.coupling is None else sets[j.coupling])
                                          for j in self.joints))

    def to_servo_deg(self, name: str, joint_deg: float) -> float:
        """A revolute joint's angle [deg] -> the servo angle [deg] that puts the joint there."""
        return self.joint(name).to_servo_deg(joint_deg * DEG)

    def to_joint_deg(self, name: str, servo_deg: float) -> float:
        return self.joint(name).to_joint(servo_deg) / DEG


@dataclass(frozen=True)
class JointReading:
    """What one /joint_states message carries: SI units, joints whose position is known."""

    names: list[str]
    position_rad: np.ndarray
    velocity_rad_s: np.ndarray
    effort_a: np.ndarray


def joint_map(use: bool, names: Sequence[str], ids: Sequence[int], directions: Sequence[int],
              offsets_deg: Sequence[float]) -> JointMap | None:
    """The mapping the ``joint_state.*`` parameters describe, None when none is given; ConfigError
    with one line naming the parameter at fault when the values do not make a mapping."""
    names, ids = list(names), list(ids)
    if names == [""] and ids == [-1]:
        if use:
            raise ConfigError("parameter 'joint_state.use' is true but 'joint_state.names'/'joint_state.ids' map no "
                              "joint: give e.g. names: [pan, tilt] and ids: [1, 2]")
        return None
    n = len(names)
    if n != len(ids):
        raise ConfigError(f"parameters 'joint_state.names' ({n} names) and 'joint_state.ids' ({len(ids)} IDs) "
                          "must have the same length")
    _check_names(names)
    _check_ids(ids)
    return JointMap.simple(names, [int(i) for i in ids], [int(d) for d in _directions(directions, n)],
                           [float(o) for o in _offsets_deg(offsets_deg, n)])


def _check_names(names: list[str]) -> None:
    """Joint names are non-empty and unique."""
    empty = [k for k, name in enumerate(names) if not name.strip()]
    if empty:
        raise ConfigError(f"parameter 'joint_state.names' has an empty name at index {empty[0]}")
    dup = sorted({name for name in names if names.count(name) > 1})
    if dup:
        raise ConfigError(f"parameter 'joint_state.names' repeats {', '.join(dup)}: joint names must be unique")


def _check_ids(ids: list[int]) -> None:
    """Servo IDs are within 0..252, one joint per servo."""
    bad = [i for i in ids if not 0 <= i <= 252]
    if bad:
        raise ConfigError(f"parameter 'joint_state.ids' has {bad}: servo IDs are 0..252")
    dup_ids = sorted({i for i in ids if ids.count(i) > 1})
    if dup_ids:
        raise ConfigError(f"parameter 'joint_state.ids' repeats {dup_ids}: one joint per servo")


def _directions(given: Sequence[int], n: int) -> list:
    directions = _per_joint(given, "joint_state.directions", n)
    if any(d not in (1, -1) for d in directions):
        raise ConfigError(f"parameter 'joint_state.directions' = {directions}: each must be 1 or -1")
    return directions


def _offsets_deg(given: Sequence[float], n: int) -> list:
    offsets = _per_joint(given, "joint_state.offsets_deg", n)
    if not all(math.isfinite(o) for o in offsets):
        raise ConfigError(f"parameter 'joint_state.offsets_deg' = {offsets}: each must be a finite angle")
    return offsets


def _per_joint(values: Sequence[Any], name: str, n: int) -> list:
    given = list(values)
    if len(given) == 1:
        return given * n
    if len(given) != n:
        raise ConfigError(f"parameter '{name}' has {len(given)} values for {n} joints: give one value or one per joint")
    return given


def unhandled(mapping: JointMap, handled_ids: Iterable[int]) -> list[str]:
    """Joints whose servo is not among the handled ones (to warn about once)."""
    handled = set(handled_ids)
    return [j.name for j in mapping.joints if any(i not in handled for i in j.servo_ids)]


def effort_per_amp(mapping: JointMap, scale: float, model: Model) -> float:
    """A servo's present current [A] -> its part of the joint's effort (``scale``: the servo's, in
    joint units per servo degree): its direction in A; in N·m (N for a prismatic joint) the
    model's e-Manual torque per ampere through the joint's reduction (NaN without figures)."""
    if mapping.effort_unit == "A":
        return math.copysign(1.0, scale)
    figures = torque_figures(model.name)
    return math.nan if figures is None else figures.nm_per_a * DEG / scale


def read_joints(mapping: JointMap, table: ServoTable) -> JointReading:
    """The joints of ``table`` in SI units (parameter order, then the mimic joints); joints whose
    servo is not handled or whose position was never read are left out rather than published as
    NaN. A joint driven by several servos is the mean of theirs, a joint of a coupled set its
    row of the set's servos. Effort is the present current [A] with the joint's direction, or N·m
    (``effort_per_amp``), summed over a joint's servos; NaN for a coupled joint."""
    position = table.units("present_position")
    velocity = table.units("present_velocity")
    current = table.units("present_current")
    names: list[str] = []
    pos_out, vel_out, eff_out = [], [], []
    for joint in mapping.joints:
        rows = [(table.index.get(i), scale) for i, scale in joint.servos]
        if any(p is None or not math.isfinite(position[p]) for p, _ in rows):
            continue
        per_amp = [effort_per_amp(mapping, scale, table.model(i)) for i, scale in joint.servos]
        names.append(joint.name)
        share = 1.0 if joint.coupling is not None else 1.0 / len(rows)  # a row's sum, or the pair's mean
        pos_out.append(joint.zero + share * sum(scale * position[p] for p, scale in rows))
        vel_out.append(share * sum(scale * velocity[p] for p, scale in rows))
        eff_out.append(math.nan if joint.coupling is not None else
                       sum(k * current[p] for (p, _), k in zip(rows, per_amp)) / 1000.0)
    reading = JointReading(names=names, position_rad=np.asarray(pos_out, dtype=np.float64),
                           velocity_rad_s=np.asarray(vel_out, dtype=np.float64), effort_a=np.asarray(eff_out, dtype=np.float64))
    return _with_mimics(mapping, reading)


def spread(joint: Joint, table: ServoTable) -> float:
    """How far apart a joint's servos put it [joint units] as last read (0: one servo, or unread)."""
    position = table.units("present_position")
    at = [joint.zero + scale * position[table.index[i]] for i, scale in joint.servos if i in table.index]
    at = [p for p in at if math.isfinite(p)]
    return max(at) - min(at) if len(at) > 1 else 0.0


def settled(joint: Joint, table: ServoTable) -> bool:
    """Whether each of a joint's servos is within the joint's ``disagreement`` of its own goal (as
    last written or read; a servo without a known goal counts as there): servos that merely pass
    each other on the way to their goals are not there yet."""
    present, goal = table.units("present_position"), table.units("goal_position")
    for dxl_id, scale in joint.servos:
        p = table.index.get(dxl_id)
        if p is not None and math.isfinite(goal[p]) and abs(scale * (present[p] - goal[p])) > joint.disagreement:
            return False
    return True


def _with_mimics(mapping: JointMap, reading: JointReading) -> JointReading:
    """The mimic joints added after the others: multiplier x the followed joint + offset."""
    if not mapping.mimics:
        return reading
    at = {name: k for k, name in enumerate(reading.names)}
    follow = [(m, at[m.of]) for m in mapping.mimics if m.of in at]
    if not follow:
        return reading
    k = np.array([i for _, i in follow], dtype=np.int64)
    mult = np.array([m.multiplier for m, _ in follow], dtype=np.float64)
    offset = np.array([m.offset for m, _ in follow], dtype=np.float64)
    return JointReading(names=reading.names + [m.name for m, _ in follow],
                        position_rad=np.concatenate([reading.position_rad, mult * reading.position_rad[k] + offset]),
                        velocity_rad_s=np.concatenate([reading.velocity_rad_s, mult * reading.velocity_rad_s[k]]),
                        effort_a=np.concatenate([reading.effort_a, np.full(len(follow), math.nan)]))


def resolve_targets(mapping: JointMap | None, ids: Sequence[int], names: Sequence[str]) -> list[tuple[int, str | None]]:
    """(servo ID, joint name or None) of a request that names servos either by ID or by joint
    name; ValueError with the reason when it does neither, both, or names an unknown joint."""
    if len(ids) and len(names):
        raise ValueError("give either ids or joint names, not both")
    if not len(ids) and not len(names):
        raise ValueError("no ids and no joint names given")
    if len(ids):
        return _targets_by_id(ids)
    return _targets_by_name(mapping, names)


def _targets_by_id(ids: Sequence[int]) -> list[tuple[int, str | None]]:
    bad = [int(i) for i in ids if not 0 <= int(i) <= 252]
    if bad:
        raise ValueError(f"IDs {some_ids(bad)} are outside 0..252")
    return [(int(i), None) for i in ids]


def _targets_by_name(mapping: JointMap | None, names: Sequence[str]) -> list[tuple[int, str | None]]:
    if mapping is None:
        raise ValueError("joint names given but no joint_state.names/ids mapping is configured")
    known = {j.name: j.servo_ids for j in mapping.joints}
    unknown = [name for name in names if name not in known]
    if unknown:
        more = f" and {len(unknown) - 1} more" if len(unknown) > 1 else ""
        raise ValueError(f"unknown joint '{cut(unknown[0])}'{more} (known: {cut(', '.join(mapping.names))})")
    return [(i, name) for name in names for i in known[name]]  # every servo of a joint
