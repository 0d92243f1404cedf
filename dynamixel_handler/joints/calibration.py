"""Joint offsets measured from outside and kept in a file (``joints_calibration.path``).

``dynamixel/calibrate_offsets`` names joints and where each one is now, in its units (rad, or m for
a prismatic joint), as something the owner trusts measured it (a jig, a level, a camera). Each
named joint's zero (its position when its servo reads 0 deg) moves so that the joint reads that
position now; no servo is written. The zeros are kept in a small YAML file, loaded at the next start
over the parameters' offsets:

    # dynamixel_handler joint offsets ...
    joint_offsets:
      shoulder: 0.1523
      gripper: -0.0012

The joint map in use is one ``LiveJoints``: read by every joint door, replaced whole (never changed
in place) by the calibration on the loop thread. ROS-free.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml

from ..errors import ConfigError
from ..logs import cut, cut_path
from ..servo.table import ServoTable
from .mapping import JointMap, read_joints

#: the file's one key
FILE_KEY = "joint_offsets"
#: the largest calibration file read [bytes]
MAX_FILE_BYTES = 1_000_000


class LiveJoints:
    """The joint map as calibrated now: ``map`` is read anywhere (one reference, replaced whole by
    ``calibrate`` on the loop thread, so a reader sees the old map or the new one, never half)."""

    def __init__(self, joint_map: JointMap) -> None:
        self._map = joint_map

    @classmethod
    def of(cls, joints: JointMap | LiveJoints) -> LiveJoints:
        """``joints`` as they are (a map that never changes: one no calibration replaces)."""
        return joints if isinstance(joints, LiveJoints) else cls(joints)

    @property
    def map(self) -> JointMap:
        return self._map

    def calibrate(self, zeros: Mapping[str, float]) -> JointMap:
        self._map = self._map.with_zeros(zeros)
        return self._map


@dataclass(frozen=True)
class Calibration:
    """What one calibration asks for: joints by name and where each is now."""

    names: tuple[str, ...]
    positions: tuple[float, ...]

    def refusal(self, mapping: JointMap) -> str:
        """Why the request cannot be taken as it is ("": it can), before anything is read."""
        if not self.names:
            return "no joint named"
        if len(self.names) != len(self.positions):
            return f"{len(self.names)} joint names but {len(self.positions)} positions: one position per joint"
        twice = sorted({n for n in self.names if self.names.count(n) > 1})
        if twice:
            return f"joint {cut(twice[0])} named twice"
        mimics = {m.name for m in mapping.mimics}
        for name, position in zip(self.names, self.positions):
            if name in mimics:
                return f"{cut(name)} is a mimic joint (state only): calibrate the joint it follows"
            if name not in mapping.names:
                return f"unknown joint '{cut(name)}' (known: {cut(', '.join(mapping.names))})"
            if not math.isfinite(position) or abs(position) > 1e6:
                return f"{cut(name)}: position {position!r} is not a finite number in the joint's units"
        return ""

    def zeros(self, mapping: JointMap, table: ServoTable) -> tuple[dict[str, float], str]:
        """Each named joint's new zero from the positions last read ({} and why when one of its
        servos has no position read)."""
        reading = read_joints(mapping, table)
        now = dict(zip(reading.names, reading.position_rad.tolist()))
        unread = [n for n in self.names if n not in now]
        if unread:
            ids = list(mapping.joint(unread[0]).servo_ids)
            return {}, f"{cut(unread[0])}: no present position of servo(s) {ids} read (not handled, or not answering)"
        return {n: mapping.joint(n).zero + p - now[n] for n, p in zip(self.names, self.positions)}, ""


def described(before: JointMap, after: JointMap, names: Sequence[str]) -> str:
    """One line per joint: its zero before and after."""
    def unit(name: str) -> str:
        return "m" if after.joint(name).prismatic else "rad"
    return "; ".join(f"{n}: offset {before.joint(n).zero + 0.0:.6g} -> {after.joint(n).zero + 0.0:.6g} {unit(n)}"
                     for n in names)  # + 0.0: no "-0"


def offsets_yaml(mapping: JointMap) -> str:
    """The file: every joint's zero (the whole robot, so that one file says it all)."""
    lines = ["# dynamixel_handler joint offsets: each joint's position [rad, or m for a prismatic joint] when its",
             "# servo(s) read 0 deg, set by dynamixel/calibrate_offsets; loaded at start over the parameters' offsets.",
             f"{FILE_KEY}:"]
    lines += [f"  {json.dumps(j.name)}: {j.zero!r}" for j in mapping.joints]  # a JSON string is a YAML key
    return "\n".join(lines) + "\n"


def load(path: Path, mapping: JointMap) -> tuple[JointMap, str]:
    """``mapping`` with the zeros of the file at ``path`` and one line saying what was loaded; a
    missing file loads nothing (the line says so); a file that cannot be read or is not a
    calibration: ConfigError naming it (the robot's offsets would be wrong)."""
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        return mapping, f"no joint calibration saved at {cut_path(path)} yet: the parameters' offsets are used"
    except OSError as exc:
        raise ConfigError(f"joints_calibration.path {cut_path(path)}: cannot be read ({exc.strerror})") from None
    if size > MAX_FILE_BYTES:
        raise ConfigError(f"joints_calibration.path {cut_path(path)}: {size} bytes, more than a calibration "
                          f"({MAX_FILE_BYTES}) can be")
    zeros = _zeros_of(path)
    unknown = [n for n in zeros if n not in mapping.names]
    known = {n: z for n, z in zeros.items() if n in mapping.names}
    line = f"joint offsets of {', '.join(known) or 'no joint'} loaded from {cut_path(path)}"
    if unknown:
        line += f" (not joints of this robot, ignored: {cut(', '.join(unknown))})"
    return mapping.with_zeros(known), line


def _zeros_of(path: Path) -> dict[str, float]:
    try:
        data: Any = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        why = getattr(exc, "strerror", None) or type(exc).__name__
        raise ConfigError(f"joints_calibration.path {cut_path(path)}: not a readable YAML file ({why})") from None
    zeros = data.get(FILE_KEY) if isinstance(data, dict) else None
    if not isinstance(zeros, dict):
        raise ConfigError(f"joints_calibration.path {cut_path(path)}: no '{FILE_KEY}:' map of joint name to offset")
    for name, zero in zeros.items():
        if not isinstance(name, str) or isinstance(zero, bool) or not isinstance(zero, (int, float)) \
                or not math.isfinite(zero):
            raise ConfigError(f"joints_calibration.path {cut_path(path)}: {cut(repr(name))}: {cut(repr(zero))} is not "
                              "a joint name with a finite offset")
    return {name: float(zero) for name, zero in zeros.items()}


__all__ = ["FILE_KEY", "Calibration", "LiveJoints", "described", "load", "offsets_yaml"]
