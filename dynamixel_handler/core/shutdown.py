"""Leaving the servos as term/* say when the node exits, in a few group transactions.

Each step is one sync write (or sync read) per control-table layout over all the servos, not one
transaction per servo: on a slow bus (20 servos at 9600 bps) that is what lets the node exit in
the wire time of about five packets instead of a hundred."""
from __future__ import annotations

from typing import Iterable, Mapping

from .. import units
from .servo_io import ServoIO

#: the goal that stops a servo in a mode that has no position to hold
NEUTRAL_GOAL = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}


class Shutdown(ServoIO):
    """term/torque_auto_disable, term/servo_auto_stop."""

    def shutdown(self) -> None:
        """Leave the servos as term/* say. term/torque_auto_disable: torque off. Otherwise, with
        term/servo_auto_stop, every servo stops where it is and keeps holding: velocity, current
        and PWM goals := 0, goal position := present position, then torque off and on again on
        the servos whose torque is on (that also ends a profile move in progress). The bus
        watchdogs the handler armed are switched off (the goals that stop the servos are
        written)."""
        cfg = self.config
        ids = list(self.table.ids)
        if not self.bus.is_open or not ids:
            return
        stop = cfg["term/servo_auto_stop"]
        if stop:
            self._neutral_goals(ids)
        if cfg["term/torque_auto_disable"]:
            self.write_group("torque_enable", {i: 0 for i in ids})
        elif stop:
            self._hold_where_they_are(ids)
        self.write_group("bus_watchdog", {i: 0 for i in ids if i not in self.watchdog_user
                                          and self.table.model(i).has("bus_watchdog")
                                          and self.table.value("bus_watchdog", i)})

    def _neutral_goals(self, ids: list[int]) -> None:
        """Velocity, current and PWM goals := 0 in the servos of those modes."""
        neutral: dict[str, dict[int, int]] = {}
        for dxl_id in ids:
            item = NEUTRAL_GOAL.get(self.mode(dxl_id) or "")
            if item:
                neutral.setdefault(item, {})[dxl_id] = 0
        for item, values in neutral.items():
            self.write_group(item, values)

    def _hold_where_they_are(self, ids: list[int]) -> None:
        present = self.read_group("present_position", ids)
        goals = {}
        for dxl_id, pulses in present.items():
            goals[dxl_id] = self._clip_to_position_limits(dxl_id, pulses) if self.mode(dxl_id) == "position" else pulses
        self.write_group("goal_position", goals)
        torque_on = [i for i, on in self.read_group("torque_enable", ids).items() if on == 1]
        self.write_group("torque_enable", {i: 0 for i in torque_on})
        self.write_group("torque_enable", {i: 1 for i in torque_on})

    # ---------------------------------------------------------------- group transactions
    def _layouts(self, item: str, ids: Iterable[int]) -> dict[tuple[int, int], list[int]]:
        """The servos of ``ids`` that have ``item``, by its (address, size) in their model."""
        out: dict[tuple[int, int], list[int]] = {}
        for dxl_id in ids:
            model = self.table.model(dxl_id)
            if model.has(item):
                spec = model.item(item)
                out.setdefault((spec.address, spec.size), []).append(dxl_id)
        return out

    def read_group(self, item: str, ids: Iterable[int]) -> dict[int, int]:
        """``item`` of the servos that answered, one sync read per layout; kept in the table."""
        values: dict[int, int] = {}
        for (address, size), members in self._layouts(item, ids).items():
            replies = self.bus.sync_read(address, size, members)
            for dxl_id, data in replies.items():
                spec = self.table.model(dxl_id).item(item)
                values[dxl_id] = int(units.decode(spec, data)[0])
                self.table.set_value(item, dxl_id, values[dxl_id])
        return values

    def write_group(self, item: str, values: Mapping[int, int]) -> None:
        """``item`` := ``values`` ({ID: pulses}), one sync write per layout; kept in the table."""
        for (address, size), members in self._layouts(item, values).items():
            data = {i: units.encode(self.table.model(i).item(item), [values[i]]) for i in members}
            if self.bus.sync_write(address, size, data):
                for dxl_id in members:
                    self.table.set_value(item, dxl_id, values[dxl_id])
            else:
                self.log.warning(f"shutdown: writing {item} to IDs {members} failed: {self.bus.last_failure}")
