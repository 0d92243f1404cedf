"""``led_status``: each servo's LED shows its state. Off by default, so an owner's own use of the
LEDs is kept.

State, first that applies: hardware error, E-stop engaged, torque on, torque off. Models with an
RGB LED (P, PRO+ A: LED Red/Green/Blue 0..255) show red, yellow, green and blue; the XL-320 the same
with its colour bits; a model with one LED (X, Protocol 1.0) lights it on a hardware error and
while the E-stop is engaged, and turns it off otherwise. Written with the loop's next sync writes
when the state changes, or when the LED read back does not show it (a reboot or a power cycle
turned it off)."""
from __future__ import annotations

from typing import Callable

from ..servo import error_state
from ..servo.table import PendingWrites, ServoTable

__all__ = ["COLOURS", "LedStatus", "STATES"]

#: the states, in the order they win
STATES = ("error", "e_stop", "torque_on", "torque_off")
#: state -> (red, green, blue) of an RGB LED
COLOURS = {"error": (255, 0, 0), "e_stop": (255, 255, 0), "torque_on": (0, 255, 0), "torque_off": (0, 0, 255)}
#: XL-320 LED colour bits (red 1, green 2, blue 4) of each state
_BITS = {"error": 1, "e_stop": 3, "torque_on": 2, "torque_off": 4}
_RGB = ("led_red", "led_green", "led_blue")


class LedStatus:
    """After each step's reads (``show``): the LED writes of the servos whose state changed."""

    def __init__(self, table: ServoTable, pending: PendingWrites, engaged: Callable[[], object],
                 enabled: bool = False) -> None:
        self.table, self.pending, self.engaged, self.enabled = table, pending, engaged, enabled
        self._shown: dict[int, str] = {}  # ID -> the state its LED was last given

    def show(self) -> None:
        if not self.enabled or not len(self.table):
            return
        writes: dict[str, dict[int, int]] = {}
        for dxl_id, state in self._states():
            if self._shown.get(dxl_id) == state and self._still_shown(dxl_id, state):
                continue
            for item, value in self._values(dxl_id, state).items():
                writes.setdefault(item, {})[dxl_id] = value
            self._shown[dxl_id] = state
        if writes:
            self.pending.put_many(writes.items())

    def _states(self) -> list[tuple[int, str]]:
        """(ID, state) of each servo whose torque was read (or that is in error)."""
        table = self.table
        failing = error_state.in_error(table)
        stop = self.engaged() is not None
        torque, known = table.pulses("torque_enable"), table.known("torque_enable")
        return [(dxl_id, "error" if failing[pos] else "e_stop" if stop else "torque_on" if torque[pos] else "torque_off")
                for pos, dxl_id in enumerate(table.ids) if known[pos] or failing[pos]]

    def _values(self, dxl_id: int, state: str) -> dict[str, int]:
        model = self.table.model(dxl_id)
        if all(model.has(item) for item in _RGB):
            return dict(zip(_RGB, COLOURS[state]))
        if model.has("led_colour"):
            return {"led_colour": _BITS[state]}
        if model.has("led"):
            return {"led": int(state in ("error", "e_stop"))}
        return {}

    def _still_shown(self, dxl_id: int, state: str) -> bool:
        """The LED as last read or written shows ``state`` (a reboot turns it off)."""
        for item, value in self._values(dxl_id, state).items():
            read = self.table.value(item, dxl_id)
            if read is not None and read != value and dxl_id not in self.pending.peek(item):
                return False
        return True

    def forget(self, dxl_id: int) -> None:
        self._shown.pop(dxl_id, None)

