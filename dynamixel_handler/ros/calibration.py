"""The joints' offsets measured from outside: loaded at start from ``joints_calibration.path``,
set by ``dynamixel/calibrate_offsets`` (``services.py``, a ``CalibrateJob`` of the loop) and saved
there by the service's thread, never by the loop.

The file is written as the snapshot's is (``files.write_atomically``): to a temporary file in
the same folder, renamed over the old one; a symbolic link, a FIFO, a device or a folder at the
path is refused (``files.refusal``). A file that cannot be read at start stops the start-up
(exit code 2): the robot's joints would be off by what it holds."""
from __future__ import annotations

import os
from pathlib import Path

from ..joints import JointMap, LiveJoints
from ..joints.calibration import load, offsets_yaml
from ..logs import cut_path
from .files import refusal, write_atomically

__all__ = ["live_joints", "save"]


def path_of(node) -> Path | None:
    given = node.settings.ros.calibration_path
    return Path(os.path.expanduser(given)) if given else None


def live_joints(node) -> LiveJoints | None:
    """The node's joints with the saved offsets (one line says what was loaded); None without joints
    (``move_to`` takes joint names wherever a mapping is given, the joint topics need joint_state.use)."""
    mapping = node.settings.ros.joints
    if mapping is None:
        return None
    path = path_of(node)
    if path is not None:
        mapping, line = load(path, mapping)  # ConfigError: start-up stops with its line
        node.get_logger().info(line)
    return LiveJoints(mapping)


def save(node, mapping: JointMap) -> tuple[bool, str, str]:
    """``mapping``'s offsets written to joints_calibration.path: (saved, path, why not)."""
    path = path_of(node)
    if path is None:
        return False, "", "not saved: joints_calibration.path is not set (in use until the node stops)"
    why = refusal(path, node.handler.bus.device)
    if why:
        return False, str(path), f"not saved: joints_calibration.path {cut_path(path)} {why}"
    try:
        write_atomically(path, offsets_yaml(mapping))
    except OSError as exc:
        return False, str(path), f"not saved: {cut_path(path)}: {exc.strerror or type(exc).__name__}"
    return True, str(path), f"saved to {cut_path(path)}"
