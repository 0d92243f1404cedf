"""What a command can ask of the core, as values: one frozen dataclass per request, and its
typed answer.

The command side builds these and hands them to the core (``ServoAccess.ask`` in the loop thread,
``ServoAccess.submit`` from any thread); the core's ``Intake`` hands each to the one part that
does it through a table from request type to handler. A request is data only (no code in it), so
a walk through the code follows it by its type."""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, Mapping

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


def later(why: str | None) -> Answer | None:
    """A mode change's wait as an answer (None: it may go ahead now)."""
    return None if why is None else Answer(Outcome.LATER, later=Later(why))


# ---------------------------------------------------------------- requests the core itself does
@dataclass(frozen=True)
class SetGoals:
    """Goal values {item: {ID: pulses}} for the next sync writes (a tripped watchdog cleared first)."""

    writes: Mapping[str, Mapping[int, int]]
    what: str = "goals"


@dataclass(frozen=True)
class ChangeMode:
    """The servo to ``mode`` (the caller checked that its model has it)."""

    dxl_id: int
    mode: str
    what: str = "mode"


@dataclass(frozen=True)
class DeferModeChange:
    """A mode change that answered LATER, with the request to run again once it may (``then``)."""

    dxl_id: int
    why: Later
    then: object
    what: str = "mode (deferred)"


@dataclass(frozen=True)
class CancelDeferred:
    """A later request for the servo wins over a mode change waiting for it."""

    dxl_id: int
    what: str = "cancel deferred"


@dataclass(frozen=True)
class TorqueOn:
    """Torque on without a jump (goals := present state first)."""

    dxl_id: int
    what: str = "torque on"


@dataclass(frozen=True)
class TorqueOff:
    dxl_id: int
    what: str = "torque off"


@dataclass(frozen=True)
class WriteItem:
    """One RAM item of one servo, written now."""

    dxl_id: int
    item: str
    pulses: int
    what: str = "write"


@dataclass(frozen=True)
class WriteEeprom:
    """One EEPROM item of one servo, spared and coalesced (``Deferred.write_eeprom``)."""

    dxl_id: int
    item: str
    pulses: int
    what: str = "eeprom write"


@dataclass(frozen=True)
class Reboot:
    """A reboot, at most once per clear_error_interval_sec per servo."""

    dxl_id: int
    what: str = "reboot"


@dataclass(frozen=True)
class ClearError:
    """A hardware error cleared (reboot or error clear instruction); turns kept with ``keep_rotation``."""

    dxl_id: int
    keep_rotation: bool
    what: str = "clear error"


@dataclass(frozen=True)
class AddServo:
    """Ping the ID and handle it if it answers with a model of a used series."""

    dxl_id: int
    what: str = "add_id"


@dataclass(frozen=True)
class RemoveServo:
    """Stop handling the servo now."""

    dxl_id: int
    what: str = "remove_id"


@dataclass(frozen=True)
class WantHandled:
    """add_id (True) or remove_id (False), applied once a loop (the last request of a loop wins)."""

    dxl_id: int
    handled: bool
    what: str = "add_id / remove_id"


@dataclass(frozen=True)
class SetUserWatchdog:
    """The bus watchdog time the user asked for (0: off), kept whatever the mode."""

    dxl_id: int
    pulses: int
    what: str = "bus watchdog"


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


#: the requests the core's parts do themselves (the command side adds its own kinds)
CORE_REQUESTS = (SetGoals, ChangeMode, DeferModeChange, CancelDeferred, TorqueOn, TorqueOff, WriteItem,
                 WriteEeprom, Reboot, ClearError, AddServo, RemoveServo, WantHandled, SetUserWatchdog, EngageStop,
                 ReleaseStop)
