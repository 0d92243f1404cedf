"""The answer of everything a command asks of the core (``Answer``), and the core's own queued
requests (the E-stop's).

In the loop thread the command side asks through typed methods (``calls.CoreCalls``), each
answering an ``Answer``. What crosses threads is a request value, queued (``ServoAccess.submit``)
and handed by the ``Intake`` to the one part that takes its type; the command side's own request
values are in ``commands.command_types``. A request is data only (no code in it), so a walk
through the code follows it by its type."""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from ..bus import Result


class Outcome(enum.Enum):
    """How a request ended."""

    DONE = "done"          # applied (or nothing needed doing)
    LATER = "later"        # not now: ``Answer.later`` says why (a mode change asked for too soon)
    FAILED = "failed"      # the bus did not do it: ``Answer.failure`` says why
    REFUSED = "refused"    # not allowed (a rule, a limit of time): ``Answer.failure`` says why


class Later(enum.Enum):
    """Why a mode change waits."""

    INTERVAL = "interval"      # the last change was less than mode_change_interval_sec ago
    BUS_TIME = "bus time"      # this loop's mode changes used their bus time (``Pacing.ops_wait``)
    STOPPING = "stopping"      # the node is stopping: the request is dropped
    RETRY = "retry"            # the bus did not take the change (no reply, refused): tried again soon


@dataclass(frozen=True, slots=True)
class Answer:
    """A request's outcome; ``failure`` the line a user can act on, ``later`` why it waits. True
    in a condition when it was done."""

    outcome: Outcome = Outcome.DONE
    failure: str = ""
    later: Later | None = None

    def __bool__(self) -> bool:
        return self.outcome is Outcome.DONE


DONE = Answer()


def answer(result: Result[Any] | bool, failure: str = "") -> Answer:
    """A bus call's ``Result`` (or a plain truth value) as an ``Answer``."""
    if isinstance(result, Result):
        return DONE if result else Answer(Outcome.FAILED, result.why)
    return DONE if result else Answer(Outcome.FAILED, failure)


def later(why: Later | None) -> Answer | None:
    """A mode change's wait as an answer (None: it may go ahead now)."""
    return None if why is None else Answer(Outcome.LATER, later=why)


# ---------------------------------------------------------------- queued requests the core takes
@dataclass(frozen=True)
class EngageStop:
    """Every servo holds; moving requests are refused until ``ReleaseStop``."""

    why: str
    what: str = "e-stop"


@dataclass(frozen=True)
class ReleaseStop:
    """New commands are taken again (nothing moves by itself: the held goals stay)."""

    why: str
    what: str = "e-stop release"
