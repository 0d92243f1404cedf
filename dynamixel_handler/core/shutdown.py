"""Leaving the servos as term/* say when the node exits."""
from __future__ import annotations

from .servo_io import ServoIO


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
        if not self.bus.is_open:
            return
        ids = list(self.table.ids)
        stop = cfg["term/servo_auto_stop"]
        for dxl_id in ids:
            if stop:
                mode = self.mode(dxl_id)
                neutral = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}.get(mode or "")
                if neutral:
                    self.write_item(dxl_id, neutral, 0)
            if cfg["term/torque_auto_disable"]:
                self.torque_off(dxl_id)
            elif stop:
                present = self.read_item(dxl_id, "present_position")
                if present is not None:
                    if self.mode(dxl_id) == "position":
                        present = self._clip_to_position_limits(dxl_id, present)
                    self.write_item(dxl_id, "goal_position", present)
                if self.read_item(dxl_id, "torque_enable") == 1:
                    self.write_item(dxl_id, "torque_enable", 0)
                    self.write_item(dxl_id, "torque_enable", 1)
            if (self.table.model(dxl_id).has("bus_watchdog") and dxl_id not in self.watchdog_user
                    and self.table.value("bus_watchdog", dxl_id)):
                self.write_item(dxl_id, "bus_watchdog", 0)
