"""The file ``calibrate`` writes: a parameters file the node takes (``--params-file``) holding the
``joints`` block of the calibrated joints, one entry per servo (``id``, ``direction`` 1,
``reduction`` 1.0, ``offset`` [rad] so that the joint reads 0 at the zero pose, ``limits.position``
[rad]: the range moved through by hand, a margin inside at each end). The text is checked with the
node's own parser (:func:`dynamixel_handler.joints.block.joints_block`) before it is written, and
written atomically (a temporary file in the same folder, then renamed): an interrupted run leaves
no half file, and an existing file is replaced only when asked to."""
from __future__ import annotations

import argparse
import datetime
import math
import os
import re
import tempfile
from dataclasses import dataclass
from typing import Any, Mapping

from ..errors import ConfigError
from ..joints.block import joints_block
from .errors import BadArguments, StepFailed, cut, cut_path
from .values import number

__all__ = ["Calibrated", "parse_names", "parse_margin", "check_target", "joints_yaml", "check_parsed", "write_atomically"]

#: a joint name the parameters file can hold as a key (the node reads ``joints.<name>.<key>``)
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")
#: the widest margin taken [deg]
MARGIN_MAX_DEG = 90.0


@dataclass
class Calibrated:
    """One joint as calibrated: its servo, the range moved through and the servo's angle at the
    zero pose [deg, the servo's angle as the handler reads it], the margin [deg] and whether the
    servo's Homing Offset now makes it read 0 there (then the offset is 0)."""

    name: str
    dxl_id: int
    low_deg: float
    high_deg: float
    zero_deg: float
    margin_deg: float
    homed: bool = False

    @property
    def offset_rad(self) -> float:
        """joint = offset + servo angle [rad]: 0 at the zero pose."""
        return 0.0 if self.homed else -math.radians(self.zero_deg)

    @property
    def limits_deg(self) -> tuple[float, float]:
        """The joint's limits [deg from the zero pose]: the range moved through, the margin inside."""
        return (self.low_deg - self.zero_deg + self.margin_deg, self.high_deg - self.zero_deg - self.margin_deg)

    @property
    def limits_rad(self) -> tuple[float, float]:
        lo, hi = self.limits_deg
        return math.radians(lo), math.radians(hi)


def parse_names(text: str) -> list[str]:
    """``--names shoulder,elbow``: joint names, each a key a parameters file can hold, none twice."""
    names = [n.strip() for n in text.split(",")]
    for name in names:
        if not _NAME.match(name):
            raise argparse.ArgumentTypeError(f"'{cut(name)}' is not a joint name (a letter, then letters, digits or _; "
                                             "at most 64)")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"joint name {twice[0]} is given twice")
    return names


def parse_margin(text: str) -> float:
    """``--margin-deg 5``: degrees inside each end of the range moved through (0 .. 90)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= MARGIN_MAX_DEG):
        raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a margin of 0 to {MARGIN_MAX_DEG:g} deg")
    return value


def check_target(path: str, force: bool) -> None:
    """Before the bus is used: BadArguments when ``path`` exists and ``force`` was not given, or is
    not a regular file; StepFailed when its folder cannot take a file."""
    if os.path.lexists(path) and not force:
        raise BadArguments(f"--joints {cut_path(path)}: the file exists: refused, nothing done (give --force to "
                           "replace it, or another name)")
    if os.path.isdir(path) or (os.path.exists(path) and not os.path.isfile(path)):
        raise BadArguments(f"--joints {cut_path(path)}: not a regular file (a folder, a FIFO or a device): refused")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.access(folder, os.W_OK | os.X_OK):
        raise StepFailed(f"--joints {cut_path(path)}: its folder cannot be written: refused, nothing done")


def _float(value: float) -> str:
    return f"{value:.6f}".replace("-0.000000", "0.000000")


def joints_yaml(joints: list[Calibrated], device: str) -> str:
    """The parameters file: a header saying what it holds, then ``/**: ros__parameters: joints:``."""
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    homed = any(j.homed for j in joints)
    lines = [f"# dynamixel_handler_setup calibrate, {stamp}: the joints block of ID "
             f"{', '.join(str(j.dxl_id) for j in joints)} on {device}",
             "# joint = offset + direction x servo angle / reduction [rad]; offset: the joint reads 0 at the zero pose"
             + (" (the servos' Homing Offset was written: they read 0 there)" if homed else ""),
             f"# limits.position [rad]: the range each joint was moved through by hand, {number(joints[0].margin_deg)} "
             "deg inside each end",
             "# load it after the robot's own parameters file: --params-file robot.yaml --params-file this.yaml",
             "/**:", "  ros__parameters:", "    joints:"]
    for j in joints:
        lo, hi = j.limits_rad
        zero = "0 deg (Homing Offset)" if j.homed else f"{number(j.zero_deg)} deg"
        lines += [f"      {j.name}:", f"        id: {j.dxl_id}", "        direction: 1", "        reduction: 1.0",
                  f"        offset: {_float(j.offset_rad)}  # the servo at {zero} at the zero pose",
                  "        limits:",
                  f"          position: [{_float(lo)}, {_float(hi)}]  # moved through {number(j.low_deg - j.zero_deg)} "
                  f".. {number(j.high_deg - j.zero_deg)} deg from the zero pose"]
    return "\n".join(lines) + "\n"


def _flat(tree: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A parameters tree flattened as ROS hands it over (``joints.a.limits.position``)."""
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            flat.update(_flat(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def check_parsed(text: str, joints: list[Calibrated]) -> None:
    """The node's parser takes ``text`` and finds each joint with its servo, offset and limits
    (StepFailed, a defect, when it does not: nothing is written)."""
    import yaml

    try:
        params = yaml.safe_load(text)["/**"]["ros__parameters"]
        parsed, _ = joints_block(_flat(params))
    except (ConfigError, KeyError, TypeError, yaml.YAMLError) as exc:
        raise StepFailed(f"the joints block made is not one the handler takes ({exc}): a defect, nothing written; "
                         "please report it") from None
    for j in joints:
        got = parsed.get(j.name)
        lo, hi = j.limits_rad
        if got is None or got.dxl_id != j.dxl_id or not (math.isclose(got.zero, j.offset_rad, abs_tol=1e-5)
                                                          and _near(got.position_limits, (lo, hi))):
            raise StepFailed(f"the joints block made reads back otherwise for {j.name}: a defect, nothing written; "
                             "please report it")


def _near(got: tuple[float, float], want: tuple[float, float]) -> bool:
    return all(math.isclose(a, b, abs_tol=1e-5) for a, b in zip(got, want))


def write_atomically(path: str, text: str, replace: bool) -> None:
    """``text`` to ``path`` through a temporary file in the same folder and a rename: whole or not
    at all. Without ``replace`` a file that appeared meanwhile is kept (StepFailed)."""
    folder = os.path.dirname(os.path.abspath(path))
    handle, tmp = tempfile.mkstemp(dir=folder, prefix=f".{os.path.basename(path)}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        _place(tmp, path, replace)
    except OSError as exc:
        raise StepFailed(f"cannot write {cut_path(path)}: {exc.strerror}") from None
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def _place(tmp: str, path: str, replace: bool) -> None:
    if replace:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)  # fails where a file is: never replaces one
    except FileExistsError:
        raise StepFailed(f"--joints {cut_path(path)}: a file of that name appeared meanwhile: kept, nothing written "
                         "to it (give --force to replace it)") from None
    except OSError:  # a file system without hard links
        if os.path.lexists(path):
            raise StepFailed(f"--joints {cut_path(path)}: a file of that name appeared meanwhile: kept") from None
        os.replace(tmp, path)
