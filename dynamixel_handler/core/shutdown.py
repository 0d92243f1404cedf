"""Leaving the servos as term/* say when the node exits, in a few group transactions.

Each step is one sync write (or sync read) per control-table layout over all the servos, not one
transaction per servo: on a slow bus (20 servos at 9600 bps) that is what lets the node exit in
the wire time of about five packets instead of a hundred."""
from __future__ import annotations

from typing import Collection

from ..bus import ServoBus
from ..logs import some_ids
from ..servo.table import ServoTable
from ..settings import TermSettings
from .group_io import GroupIO
from .servo_io import Log, ServoIO

#: the goal that stops a servo in a mode that has no position to hold
NEUTRAL_GOAL = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}


class Shutdown:
    """term/torque_auto_disable, term/servo_auto_stop."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, io: ServoIO, group: GroupIO,
                 settings: TermSettings) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.io = io
        self.group = group
        self.settings = settings

    def shutdown(self, dropped: Collection[int] = (), user_watchdog: Collection[int] = ()) -> None:
        """Leave the servos as term/* say. term/torque_auto_disable: torque off. Otherwise, with
        term/servo_auto_stop, every servo stops where it is and keeps holding: velocity, current
        and PWM goals := 0, goal position := present position, then torque off and on again on
        the servos whose torque is on (that also ends a profile move in progress). The bus
        watchdogs the handler armed are switched off (the goals that stop the servos are
        written). Mode changes not made yet (queued behind others, or waiting for
        mode_change_interval_sec) are not made: those servos keep their mode (one line names them):
        ``dropped``, the IDs whose mode changes are not made; ``user_watchdog``, the IDs whose
        watchdog a command set (left as it is)."""
        ids = list(self.table.ids)
        if dropped:
            self.log.info(f"stopping: mode changes not made (dropped) for IDs {some_ids(sorted(dropped))}")
        if not self.bus.is_open or not ids:
            return
        stop = self.settings.servo_auto_stop
        if stop:
            self._neutral_goals(ids)
        if self.settings.torque_auto_disable:
            self.group.write_group("torque_enable", {i: 0 for i in ids})
        elif stop:
            self._hold_where_they_are(ids)
        self.group.write_group("bus_watchdog", {i: 0 for i in ids if i not in user_watchdog
                                                and self.table.model(i).has("bus_watchdog")
                                                and self.table.value("bus_watchdog", i)})

    def _neutral_goals(self, ids: list[int]) -> None:
        """Velocity, current and PWM goals := 0 in the servos of those modes."""
        neutral: dict[str, dict[int, int]] = {}
        for dxl_id in ids:
            item = NEUTRAL_GOAL.get(self.io.mode(dxl_id) or "")
            if item:
                neutral.setdefault(item, {})[dxl_id] = 0
        for item, values in neutral.items():
            self.group.write_group(item, values)

    def _hold_where_they_are(self, ids: list[int]) -> None:
        present = self.group.read_group("present_position", ids)
        goals = {}
        for dxl_id, pulses in present.items():
            goals[dxl_id] = self.io.clip_to_position_limits(dxl_id, pulses) if self.io.mode(dxl_id) == "position" else pulses
        self.group.write_group("goal_position", goals)
        torque_on = [i for i, on in self.group.read_group("torque_enable", ids).items() if on == 1]
        self.group.write_group("torque_enable", {i: 0 for i in torque_on})
        self.group.write_group("torque_enable", {i: 1 for i in torque_on})
