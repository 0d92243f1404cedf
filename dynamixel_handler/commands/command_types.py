"""The command side's requests as values: a message taken on any thread, checked and applied in
the loop thread by the part that registered for its type (``ServoAccess.register``).

The core's own requests (goals, a mode change, torque, ...) are in ``core.request_types``; these
are the commands before their checks, queued as they came."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from ..control_table import ServoFamily

Fields = Mapping[str, Sequence[Any]]


@dataclass(frozen=True)
class Control:
    """A control topic's command for servos of ``family`` (``Commander``)."""

    family: ServoFamily
    control: str
    ids: list[int]
    fields: Fields
    what: str = "control"


@dataclass(frozen=True)
class Goal:
    ids: list[int]
    fields: Fields
    what: str = "goal"


@dataclass(frozen=True)
class Gain:
    ids: list[int]
    fields: Fields
    what: str = "gain"


@dataclass(frozen=True)
class Limit:
    ids: list[int]
    fields: Fields
    what: str = "limit"


@dataclass(frozen=True)
class Status:
    ids: list[int]
    fields: Fields
    what: str = "status"


@dataclass(frozen=True)
class Extra:
    ids: list[int]
    fields: Fields
    what: str = "extra"


@dataclass(frozen=True)
class Shortcut:
    """One of ``tables.SHORTCUTS``' actions for ``ids`` (none or 254: all, where the action allows)."""

    action: str
    ids: list[int]
    what: str = "shortcut"


@dataclass(frozen=True)
class JointCommand:
    """Joint goals by name in SI units (``joint_goals.JointGoals``)."""

    names: list[str]
    position: list[float]
    velocity: list[float]
    effort: list[float]
    what: str = "joint goals"


@dataclass(frozen=True)
class HoldJoints:
    """Joints stopped where they are: goal position := present position."""

    ids: list[int]
    what: str = "hold"


#: the queued requests of each command-side part (its ``handle`` matches over them)
CommanderRequest = Control | Goal | Gain | Limit | Status | Extra | Shortcut
JointRequest = JointCommand | HoldJoints

#: the message groups of the command topics, each with its request type (topics register from this)
GROUPS: dict[str, type[Goal | Gain | Limit | Status | Extra]] = {
    "goal": Goal, "gain": Gain, "limit": Limit, "status": Status, "extra": Extra}


@dataclass(frozen=True)
class TorqueStep:
    """The next servos of a torque job (``moves.TorqueJob``), written in the loop thread."""

    job: Any
    what: str = "torque"


@dataclass(frozen=True)
class StartMove:
    """A move job's goals written (``moves.Book.start``)."""

    job: Any
    what: str = "move"


@dataclass(frozen=True)
class MoveWritten:
    """A move job's goals as written, after the requests before it (``moves.Book``)."""

    job: Any
    what: str = "move (goals written)"



MoveRequest = TorqueStep | StartMove | MoveWritten
