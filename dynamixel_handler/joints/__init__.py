"""The robot's joints over the servos: the mapping (``mapping``), the ``joints`` block of the
parameters (``block``) and the offsets measured from outside (``calibration``)."""
from .block import is_joint_parameter, joints_block, merged
from .calibration import LiveJoints
from .mapping import (
    DEG,
    EFFORT_UNITS,
    Coupling,
    Joint,
    JointMap,
    JointReading,
    Mimic,
    effort_per_amp,
    joint_map,
    read_joints,
    resolve_targets,
    settled,
    spread,
    unhandled,
)

__all__ = ["DEG", "EFFORT_UNITS", "Coupling", "Joint", "JointMap", "JointReading", "LiveJoints", "Mimic", "effort_per_amp",
           "is_joint_parameter", "joint_map", "joints_block", "merged",
           "read_joints", "resolve_targets", "settled", "spread", "unhandled"]
