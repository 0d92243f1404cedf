"""What the torque and move services check before anything reaches the loop, and how a waiting move
ends. ROS-free: the services (``services.py``) and the jobs (``moves.py``) use it.

A request is checked at once, on the thread that took it: servos named either by ID or by joint
name, none twice, no more than the node handles, one finite position each. It is refused with one
short line (values echoed are cut to about 80 characters, "(N more)") before any bus work.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

from ..joints import DEG, JointMap, resolve_targets
from ..logs import ECHO_MAX

DEFAULT_TOLERANCE_DEG = 1.0
DEFAULT_TIMEOUT_S = 10.0
#: a servo that has not answered for this long ends a waiting move with ERROR [s] (one missed read does not)
SILENT_S = 0.5

#: how a request ends (the services map them to their messages' fields)
REACHED, TIMED_OUT, CANCELED, ERROR, PREEMPTED, DONE = range(6)

Targets = list[tuple[int, "str | None"]]


class MoveError(RuntimeError):
    """A request that cannot be carried out; the message says why, in words for the caller."""


def listed(values: Iterable[object], limit: int = ECHO_MAX) -> str:
    """``values`` comma-separated, cut to about ``limit`` characters: "1, 2, 3 (9997 more)"."""
    items = [str(v) for v in values]
    out: list[str] = []
    size = 0
    for k, item in enumerate(items):
        if out and size + len(item) + 2 > limit:
            return f"{', '.join(out)} ({len(items) - k} more)"
        out.append(item[:limit])
        size += len(item) + 2
    return ", ".join(out)


def targets_of(mapping: JointMap | None, ids: Sequence[int], names: Sequence[str], handled: int,
               positions: bool = True) -> Targets:
    """(servo ID, joint name or None) of a request (every servo of a joint of several); MoveError
    when it names no servo, both IDs and names, an unknown joint, a servo twice, or more servos
    than the node handles, and for a move (``positions``) a joint it cannot move in degrees."""
    given = len(ids) or len(names)
    try:
        targets = resolve_targets(mapping, list(ids), list(names))
    except ValueError as err:
        raise MoveError(str(err)) from None
    if positions:
        _one_angle_each(mapping, targets)
    _each_once(ids, names)
    if given > handled:
        raise MoveError(f"{given} servo{'s' if given != 1 else ''} named, {handled} handled")
    return targets


def _each_once(ids: Sequence[int], names: Sequence[str]) -> None:
    """MoveError for a joint or an ID named twice in one request."""
    counts = Counter(names) if len(names) else Counter(int(i) for i in ids)
    twice = [(k, n) for k, n in counts.items() if n > 1]
    if twice:
        what = "joints" if len(names) else "IDs"
        raise MoveError(f"{what} named more than once: {listed(f'{k} ({n} times)' for k, n in twice)}: "
                        "name each servo once")


def _one_angle_each(mapping: JointMap | None, targets: Targets) -> None:
    """MoveError for a joint a move cannot take: a prismatic one (the moves speak degrees), one of
    several servos (a move gives each servo named one angle)."""
    joints = [mapping.joint(name) for _, name in targets if name is not None and mapping is not None]
    for joint in joints:
        if joint.prismatic or joint.partners:
            why = "is prismatic: move_to and move_joints speak degrees" if joint.prismatic else \
                "is driven by several servos: move_to and move_joints give each servo one angle"
            raise MoveError(f"joint {joint.name} {why}; command it on joint_commands or follow_joint_trajectory")


def servo_goals(mapping: JointMap | None, targets: Targets, positions: Sequence[float]) -> tuple[list[float], list[str]]:
    """The servo angles [deg] of a move's positions (request frame: a servo's angle, or a revolute
    joint's angle [deg] through its map), joints within their soft limits; a note for each joint
    clamped."""
    out, notes = [], []
    for (_, name), position in zip(targets, positions):
        if name is None or mapping is None:
            out.append(position)
            continue
        joint = mapping.joint(name)
        goal = joint.clamped(position * DEG) / DEG
        if goal != position:
            lo, hi = (v / DEG for v in joint.position_limits)
            notes.append(f"joint {name}: {position:g} deg is beyond its limits [{lo:.6g}, {hi:.6g}] deg "
                         f"(joints.{name}.limits.position): moved to {goal:.6g} deg")
        out.append(joint.to_servo_deg(goal * DEG))
    return out, notes


def checked_positions(targets: Targets, positions_deg: Sequence[float], velocity_deg_s: float) -> list[float]:
    """The positions as floats; MoveError for a request that cannot be right."""
    if len(positions_deg) != len(targets):
        raise MoveError(f"{len(positions_deg)} positions for {len(targets)} servos")
    positions = [float(p) for p in positions_deg]
    bad = [name or i for (i, name), p in zip(targets, positions) if not math.isfinite(p)]
    if bad:
        raise MoveError(f"positions of {listed(bad)} are not finite numbers")
    if not math.isfinite(velocity_deg_s) or velocity_deg_s < 0:
        raise MoveError(f"velocity {velocity_deg_s} must be a finite value >= 0")
    return positions


@dataclass
class Move:
    """One move under way: its servos, their goals [servo deg] and how to judge arrival."""

    targets: Targets
    requested_deg: list[float]
    tolerance_deg: float
    deadline: float
    goal_deg: list[float] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ids(self) -> list[int]:
        return [i for i, _ in self.targets]


def with_notes(message: str, move: Move) -> str:
    return "; ".join([message] + move.notes)


class Watch:
    """How a waiting move ends: a servo silent for SILENT_S, every servo within tolerance, a
    cancel, or the deadline (in that order)."""

    def __init__(self, move: Move) -> None:
        self.move = move
        self.names = [name or f"ID {i}" for i, name in move.targets]
        self.silent_since: dict[int, float] = {}

    def verdict(self, ping: list[bool], remaining: list[float], now: float,
                cancelled: Callable[[], bool]) -> tuple[int, str] | None:
        move = self.move
        silent = self._silent(ping, now)
        if silent:
            return ERROR, f"{listed(silent)} stopped answering"
        if not self.silent_since and all(r <= move.tolerance_deg for r in remaining):
            return REACHED, with_notes(f"reached within {move.tolerance_deg:g} deg", move)
        if cancelled():
            return CANCELED, "cancelled: stopped where the servos were"
        if now >= move.deadline:
            far = [f"{n} {r:.1f} deg away" for n, r in zip(self.names, remaining) if r > move.tolerance_deg]
            return TIMED_OUT, with_notes(f"timed out: {listed(far)}", move)
        return None

    def _silent(self, ping: list[bool], now: float) -> list[str]:
        """The servos that have not answered for SILENT_S (one missed read does not count)."""
        for k, ok in enumerate(ping):
            if ok:
                self.silent_since.pop(k, None)
            else:
                self.silent_since.setdefault(k, now)
        return [self.names[k] for k, since in sorted(self.silent_since.items()) if now - since >= SILENT_S]
