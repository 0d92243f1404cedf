"""Status, gain, limit and shortcut commands -> checked requests to the core (loop thread).

A part of ``Commander`` (it supplies ``h``, ``warn``, ``known_ids`` and ``finite``)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping, Sequence

from .. import units
from ..control_table import OPERATING_MODES, ServoFamily
from ..core.request_types import (
    Answer,
)
from ..logs import cut
from .command_types import Status
from .tables import BROADCAST_ID, GAIN_FIELDS, LIMIT_FIELDS

if TYPE_CHECKING:
    from ..core.api import ServoAccess

Fields = Mapping[str, Sequence[Any]]
#: limit items that may be negative
SIGNED_LIMITS = ("max_position_limit", "min_position_limit")


class SettingsCommands:
    """Servo settings and membership: status (ping, error, mode, torque), gains, limits, shortcuts."""

    h: ServoAccess

    if TYPE_CHECKING:  # supplied by Commander
        def warn(self, msg: str) -> None: ...
        def known_ids(self, ids: Iterable[int], what: str, family: ServoFamily | None = None,
                      allow_all: bool = False) -> list[tuple[int, int]]: ...
        def finite(self, what: str, field: str, dxl_id: int, value: float) -> bool: ...
        def change_mode(self, dxl_id: int, mode: str, what: str) -> Answer: ...
        def warned(self, answer: Answer) -> Answer: ...

    # ============================================================== status
    def _status(self, ids: list[int], fields: Fields, what: str) -> None:
        others = bool(set(fields) - {"ping"})
        if "ping" in fields:  # add/remove first (at once): the other fields may concern an added ID
            self._membership(ids, fields["ping"], now=others)
        if not others:
            return  # nothing else to do: an ID just removed is no "unknown ID"
        for k, dxl_id in self.known_ids(ids, what):
            if "error" in fields:
                self.warned(self.h.core.clear_error(dxl_id, bool(fields["error"][k]), what))
            if "mode" in fields:
                self._status_mode(dxl_id, str(fields["mode"][k]).strip(), what)
            if "torque" in fields:
                if fields["torque"][k]:
                    self.torque_on(dxl_id)
                else:
                    self.h.core.torque_off(dxl_id)

    def _membership(self, ids: list[int], ping: Sequence[Any], now: bool) -> None:
        """Add (ping true) or remove (false) IDs: ``now``, or as one change per loop for each ID
        (``ServoAccess.want_handled``: the last request of the loop wins)."""
        for k, dxl_id in enumerate(ids):
            if not now:
                self.h.core.want_handled(dxl_id, bool(ping[k]))
            elif not ping[k]:
                self.h.core.remove_servo(dxl_id)
            elif not self.h.handles(dxl_id):
                self.h.core.add_servo(dxl_id)

    def _status_mode(self, dxl_id: int, mode: str, what: str) -> None:
        if mode not in OPERATING_MODES:
            self.warn(f"{what}: ID {dxl_id} unknown mode '{cut(mode)}' (known: {', '.join(OPERATING_MODES)})")
        elif self.h.mode(dxl_id) == mode:
            self.h.core.cancel_deferred(dxl_id)
        elif (changed := self.change_mode(dxl_id, mode, what)).later is not None:
            self.h.core.defer_mode_change(dxl_id, changed.later, Status([dxl_id], {"mode": [mode]}, what),
                                       f"{what}: ID {dxl_id} (deferred)")

    def torque_on(self, dxl_id: int) -> None:
        """Torque on as asked by a command: safely if it is off; a servo whose torque is already on
        keeps its goals (the safe torque on would make them the present state and stop it)."""
        if self.h.read_item(dxl_id, "torque_enable") != 1:
            self.h.core.torque_on(dxl_id)

    # ============================================================== gains and limits
    def _gain(self, ids: list[int], fields: Fields, what: str) -> None:
        writes: dict[str, dict[int, int]] = {}
        for field, values in fields.items():
            item = GAIN_FIELDS.get(field)
            if item is None:
                continue
            for k, dxl_id in self.known_ids(ids, what):
                model = self.h.model(dxl_id)
                if not model.has(item):
                    self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
                    continue
                value, top = int(values[k]), model.item(item).max_raw
                if value > top:
                    self.warn(f"ID {dxl_id} ({model.name}) '{field}' = {value} is beyond {top}: clamped to {top}")
                    value = top
                writes.setdefault(item, {})[dxl_id] = value
        if writes:
            self.h.core.set_goals(writes, what)

    def _limit(self, ids: list[int], fields: Fields, what: str) -> None:
        for k, dxl_id in self.known_ids(ids, what):
            values = self._limit_values(dxl_id, k, fields, what)
            for item, pulses in values.items():
                written = self.h.core.write_eeprom(dxl_id, item, pulses)
                if not written:
                    self.warn(f"{what}: ID {dxl_id} writing {item} failed: {written.failure}")
            if values and "limit" in self.h.settings.logs.writes:
                self.h.log.info(f"{what}: ID {dxl_id} limits written: {values}")

    def _limit_values(self, dxl_id: int, k: int, fields: Fields, what: str) -> dict[str, int]:
        """The checked limit values of one servo in pulses: {item: pulses}."""
        model = self.h.model(dxl_id)
        values: dict[str, int] = {}
        for field, item in LIMIT_FIELDS.items():
            if field not in fields or not self.finite(what, field, dxl_id, fields[field][k]):
                continue
            value = fields[field][k]
            if not model.has(item):
                self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
            elif value < 0 and item not in SIGNED_LIMITS:
                self.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} refused (negative)")
            else:
                values[item] = int(units.unit_to_pulse([model], item, [float(value)])[0])
        lo = values.get("min_position_limit", self.h.table.value("min_position_limit", dxl_id))
        hi = values.get("max_position_limit", self.h.table.value("max_position_limit", dxl_id))
        if lo is not None and hi is not None and lo > hi:
            self.warn(f"{what}: ID {dxl_id} min position limit above max: position limits ignored")
            values.pop("min_position_limit", None)
            values.pop("max_position_limit", None)
        return values

    # ============================================================== shortcut
    def _shortcut(self, action: str, ids: list[int]) -> None:
        what = f"shortcut {action}"
        if action == "add_id":  # one change per loop for each ID: the last request of the loop wins
            for dxl_id in ids:
                self.h.core.want_handled(dxl_id, True)
            return
        if action == "remove_id":
            for dxl_id in (self.h.handled_ids if not ids or ids == [BROADCAST_ID] else ids):
                self.h.core.want_handled(dxl_id, False)
            return
        act = self._shortcut_actions(what)[action]
        for _, dxl_id in self.known_ids(ids, what, allow_all=True):
            act(dxl_id)

    def _shortcut_actions(self, what: str) -> dict[str, Callable[[int], object]]:
        h = self.h
        return {
            "clear_error": lambda i: self.warned(h.core.clear_error(i, True, what)),
            "torque_on": self.torque_on,
            "torque_off": lambda i: h.core.torque_off(i),
            "disable": lambda i: h.core.torque_off(i),
            "enable": lambda i: h.core.write_item(i, "torque_enable", 1),
            "reboot": lambda i: h.core.reboot(i) and h.read_item(i, "torque_enable"),  # at most once a second per servo
            "reset_offset": lambda i: h.core.write_eeprom(i, "homing_offset", 0),
        }
