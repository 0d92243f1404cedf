"""The E-stop of the whole bus: every servo holds where it is, and nothing that would move one is
taken until it is released. ROS-free; everything happens in the loop thread, from the
``EngageStop`` and ``ReleaseStop`` requests (any thread submits them) and after each step's reads.

Hold, per operating mode, written in the step that takes the request (goals still waiting to be
written are dropped first):

    position, ex_position, cur_position   goal position := present position (one sync read)
    velocity                              goal velocity 0
    current                               goal current 0: no torque (the joint is held by its
                                          friction only; use current-based position to be held)
    pwm                                   goal PWM 0

Torque stays as it is (nothing falls); no mode is switched; mode changes waiting for their time
are dropped. While engaged, ``refusal`` (the gate of ``calls.CoreCalls``) refuses every request that would move
a servo: goals (gains and profiles alone pass), a mode change, torque on, a RAM write of a goal or
of torque on; one line a second per kind. ``on_hardware_error == "hold_all"``: a hardware error on
any servo engages it, and a release while a servo is still in error is refused."""
from __future__ import annotations

import logging
import threading
from typing import ClassVar, assert_never

import numpy as np

from ..servo import error_state
from ..servo.table import PendingWrites, ServoTable
from .deferred import Deferred
from .group_io import GroupIO
from .log_limits import LogLimits
from .request_types import Answer, EngageStop, Outcome, ReleaseStop
from .servo_io import Log, ServoIO

__all__ = ["EStop", "GOAL_ITEMS", "HOLD_GOALS"]

#: the RAM items whose write moves a servo
GOAL_ITEMS = ("goal_position", "goal_velocity", "goal_current", "goal_pwm")
#: mode -> the goal that holds it at 0 (position modes hold at the present position)
HOLD_GOALS = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}
_POSITION_MODES = ("position", "ex_position", "cur_position")


#: the queued requests the E-stop takes
StopRequest = EngageStop | ReleaseStop


class EStop:
    """The E-stop's state and its hold. ``why`` is read by any thread (``engaged_why``)."""

    TAKES: ClassVar[tuple[type, ...]] = (EngageStop, ReleaseStop)

    def __init__(self, table: ServoTable, pending: PendingWrites, io: ServoIO, group: GroupIO, work: Deferred,
                 log: Log, on_hardware_error: str = "none") -> None:
        self.table, self.pending, self.io, self.group, self.work, self.log = table, pending, io, group, work, log
        self.on_hardware_error = on_hardware_error
        self._lock = threading.Lock()
        self._why: str | None = None  # None: released
        self._faults: dict[int, str] = {}  # ID -> its hardware error, named (with hold_all)
        #: bumped at each engage and release: a publisher sends the state when it changed
        self.changes = 0
        self._limited = LogLimits(lambda level, msg: self.log.log(level, msg))

    # ---------------------------------------------------------------- any thread
    def engaged_why(self) -> str | None:
        """Why the E-stop is engaged, None when it is released."""
        with self._lock:
            return self._why

    def release_refusal(self) -> str | None:
        """Why a release would be refused now (servos still in error with hold_all), else None."""
        with self._lock:
            faults = dict(self._faults)
        if not faults:
            return None
        named = "; ".join(f"ID {i}: {text}" for i, text in sorted(faults.items()))
        return f"the E-stop stays engaged: hardware error still there ({named}); clear it first"

    # ---------------------------------------------------------------- loop thread
    def handle(self, request: StopRequest) -> Answer:
        """A queued request of the E-stop (any thread submits them)."""
        match request:
            case EngageStop(why=why):
                return self.engage(why)
            case ReleaseStop(why=why):
                return self.release(why)
            case _:
                assert_never(request)

    def engage(self, why: str) -> Answer:
        """Hold every servo; the line says why. Engaged already: nothing more (a publisher that
        repeats ``true`` costs no bus time)."""
        with self._lock:
            if self._why is not None:
                return Answer()
            self._why = why
            self.changes += 1
        held = self.hold()
        self.log.warning(f"E-stop engaged ({why}): {held}; commands that would move a servo are "
                         "refused until it is released")
        return Answer()

    def release(self, why: str) -> Answer:
        refused = self.release_refusal()
        if refused is not None:
            self._limited(logging.WARNING, f"E-stop release ({why}) refused: {refused}", "release refused")
            return Answer(Outcome.REFUSED, refused)
        with self._lock:
            was, self._why = self._why, None
            if was is not None:
                self.changes += 1
        if was is not None:
            self.log.info(f"E-stop released ({why}): commands are taken again; the servos keep the goals "
                          "they hold")
        return Answer()

    def hold(self) -> str:
        """Goals waiting are dropped and every servo given its hold goal (written with this step's
        writes); what was held, for the log line."""
        ids = list(self.table.ids)
        self.pending.drop_items(GOAL_ITEMS)
        waiting = sorted(self.work.deferred)
        for dxl_id in waiting:  # a mode change waiting for its time would move the servo later
            self.work.cancel(dxl_id)
        by_mode = self._by_mode(ids)
        at_present = [i for m in _POSITION_MODES for i in by_mode.get(m, [])]
        writes = {"goal_position": self._present(at_present), **self._zero_goals(by_mode)}
        self.pending.put_many((item, values) for item, values in writes.items() if values)
        unknown = [i for i in at_present if i not in writes["goal_position"]]
        said = f"{len(ids) - len(unknown)} servo(s) hold"
        if waiting:
            said += f", the mode changes waiting for IDs {waiting} dropped"
        return said + (f" (IDs {unknown}: no present position known, their goals are kept)" if unknown else "")

    def _by_mode(self, ids: list[int]) -> dict[str, list[int]]:
        by_mode: dict[str, list[int]] = {}
        for dxl_id in ids:
            by_mode.setdefault(self.io.mode(dxl_id) or "", []).append(dxl_id)
        return by_mode

    def _zero_goals(self, by_mode: dict[str, list[int]]) -> dict[str, dict[int, int]]:
        """Goal 0 of the servos in velocity, current and PWM modes (that have the item)."""
        return {item: {i: 0 for i in by_mode.get(mode, []) if self.table.model(i).has(item)}
                for mode, item in HOLD_GOALS.items()}

    def _present(self, ids: list[int]) -> dict[int, int]:
        """The present positions of ``ids``: one sync read, the last value read where a servo did
        not answer it (none known: left out)."""
        if not ids:
            return {}
        read = self.group.read_group("present_position", ids)
        out = {}
        for dxl_id in ids:
            present = read.get(dxl_id, self.table.value("present_position", dxl_id))
            if present is not None:
                out[dxl_id] = present
        return out

    def refusal(self, what: str) -> Answer | None:
        """The gate of a call that would move a servo (``calls.CoreCalls``): REFUSED while engaged
        (and one line a second per kind), None when released."""
        why = self._why
        if why is None:
            return None
        self._limited(logging.WARNING, f"E-stop engaged ({why}): {what} refused", f"refused {what}")
        return Answer(Outcome.REFUSED)

    def watch(self) -> None:
        """After a step's reads: with hold_all, a hardware error (new) engages; the servos in error
        are known to ``release_refusal``."""
        if self.on_hardware_error != "hold_all":
            return
        table = self.table
        failing = error_state.in_error(table) if len(table) else np.zeros(0, dtype=bool)
        with self._lock:
            faults = dict(self._faults)
        for pos, dxl_id in enumerate(table.ids):
            model = table.model(dxl_id)
            value = table.value(error_state.error_item(model), dxl_id)
            if failing[pos]:
                faults[dxl_id] = error_state.describe(model, int(value or 0))
            elif value is not None:  # read, and no error: gone (not read: as it was)
                faults.pop(dxl_id, None)
        with self._lock:
            new = sorted(set(faults) - set(self._faults))
            self._faults = faults
        if new:
            named = ", ".join(f"ID {i} ({table.model(i).name}): {faults[i]}" for i in new)
            self.engage(f"hardware error: {named}")

    def forget(self, dxl_id: int) -> None:
        """A servo no longer handled is no fault of the bus."""
        with self._lock:
            self._faults.pop(dxl_id, None)
