"""Commands in physical units -> checked writes and operations on the handled servos. ROS-free.

The ROS layer hands each command over as ``(id_list, {field: values})`` with arrays of the wrong
length already dropped (``take_fields``). Everything else happens here, *in the loop thread*
(``Commander`` queues a closure on the handler), so validation sees a consistent servo table and
no callback ever touches the bus: unknown or wrong-series IDs, NaN/inf, unknown mode strings and
out-of-range values are refused or clamped with a warning that names the ID and the field.
"""
from __future__ import annotations

import math
import time
from typing import Callable, Iterable, Mapping, Sequence


from . import units
from .control_table import OPERATING_MODES, Model
from .loop import Handler

#: control topic/field name -> operating mode it needs
CONTROL_MODES: Mapping[str, str] = {
    "pwm_control": "pwm", "current_control": "current", "velocity_control": "velocity",
    "position_control": "position", "extended_position_control": "ex_position",
    "current_base_position_control": "cur_position",
}
#: modes each series offers
SERIES_MODES: Mapping[str, frozenset[str]] = {
    "X": frozenset(OPERATING_MODES), "P": frozenset(OPERATING_MODES) - {"cur_position"},
    "PRO": frozenset({"current", "velocity", "position", "ex_position"}),
}
#: goal-like message field -> control-table item
GOAL_FIELDS: Mapping[str, str] = {
    "pwm_percent": "goal_pwm", "current_ma": "goal_current", "velocity_deg_s": "goal_velocity",
    "position_deg": "goal_position", "profile_vel_deg_s": "profile_velocity",
    "profile_acc_deg_ss": "profile_acceleration", "acceleration_deg_ss": "profile_acceleration",
}
LIMIT_FIELDS: Mapping[str, str] = {
    "temperature_limit_degc": "temperature_limit", "max_voltage_limit_v": "max_voltage_limit",
    "min_voltage_limit_v": "min_voltage_limit", "pwm_limit_percent": "pwm_limit",
    "current_limit_ma": "current_limit", "acceleration_limit_deg_ss": "acceleration_limit",
    "velocity_limit_deg_s": "velocity_limit", "max_position_limit_deg": "max_position_limit",
    "min_position_limit_deg": "min_position_limit",
}
GAIN_FIELDS: Mapping[str, str] = {
    "velocity_i_gain_pulse": "velocity_i_gain", "velocity_p_gain_pulse": "velocity_p_gain",
    "position_d_gain_pulse": "position_d_gain", "position_i_gain_pulse": "position_i_gain",
    "position_p_gain_pulse": "position_p_gain", "feedforward_2nd_gain_pulse": "feedforward_2nd_gain",
    "feedforward_1st_gain_pulse": "feedforward_1st_gain",
}
#: item -> the limit item its magnitude may not exceed
MAGNITUDE_LIMIT: Mapping[str, str] = {
    "goal_current": "current_limit", "goal_velocity": "velocity_limit", "goal_pwm": "pwm_limit",
    "profile_velocity": "velocity_limit", "profile_acceleration": "acceleration_limit",
}
SHORTCUTS: Mapping[str, str] = {
    "clear_error": "clear_error", "CE": "clear_error", "torque_on": "torque_on", "TON": "torque_on",
    "torque_off": "torque_off", "TOFF": "torque_off", "add_id": "add_id", "ADID": "add_id",
    "remove_id": "remove_id", "RMID": "remove_id", "reset_offset": "reset_offset", "enable": "enable",
    "disable": "disable", "reboot": "reboot",
}
MAX_ROTATION = 256.0
X_MULTI_TURN_GOAL = 1_048_575
BROADCAST_ID = 254

Fields = Mapping[str, Sequence]


def take_fields(what: str, id_list: Sequence[int], fields: Mapping[str, Sequence],
                warn: Callable[[str], None]) -> dict[str, list]:
    """Keep the arrays whose length equals ``id_list``'s; warn about the others (empty ones are
    simply absent). Nothing is taken when ``id_list`` is empty."""
    if len(id_list) == 0:
        return {}
    kept = {}
    for name, values in fields.items():
        if len(values) == 0:
            continue
        if len(values) != len(id_list):
            warn(f"{what}: '{name}' has {len(values)} values for {len(id_list)} IDs: ignored")
            continue
        kept[name] = list(values)
    return kept


class Commander:
    """Turns commands into pending writes and loop operations on one Handler."""

    def __init__(self, handler: Handler) -> None:
        self.h = handler
        self.log = handler.log
        self.verbose = bool(handler.config["verbose/callback"])
        self._last_mode_change: dict[int, float] = {}
        self._last_clear: dict[int, float] = {}

    # ============================================================== entry points (any thread)
    def control(self, series: str, control: str, ids: Sequence[int], fields: Fields) -> None:
        self._queue(f"{series.lower()} {control}", lambda: self._control(series, control, list(ids), fields))

    def goal(self, ids: Sequence[int], fields: Fields, what: str = "goal") -> None:
        self._queue(what, lambda: self._goal(list(ids), fields, what))

    def gain(self, ids: Sequence[int], fields: Fields, what: str = "gain") -> None:
        self._queue(what, lambda: self._gain(list(ids), fields, what))

    def limit(self, ids: Sequence[int], fields: Fields, what: str = "limit") -> None:
        self._queue(what, lambda: self._limit(list(ids), fields, what))

    def status(self, ids: Sequence[int], fields: Fields, what: str = "status") -> None:
        self._queue(what, lambda: self._status(list(ids), fields, what))

    def extra(self, ids: Sequence[int], fields: Fields, what: str = "extra") -> None:
        from .extra_commands import apply_extra
        self._queue(what, lambda: apply_extra(self, list(ids), fields, what))

    def shortcut(self, command: str, ids: Sequence[int]) -> None:
        action = SHORTCUTS.get(command.strip())
        if action is None:
            self.log.warning(f"shortcut: unknown command '{command}' (known: {', '.join(SHORTCUTS)})")
            return
        self._queue(f"shortcut {command}", lambda: self._shortcut(action, list(ids)))

    def _queue(self, what: str, op: Callable[[], None]) -> None:
        if self.verbose:
            self.log.info(f"command accepted: {what}")
        self.h.queue(what, op)

    # ============================================================== helpers (loop thread)
    def warn(self, msg: str) -> None:
        self.log.warning(msg)

    def known_ids(self, ids: Iterable[int], what: str, series: str | None = None,
                  allow_all: bool = False) -> list[tuple[int, int]]:
        """(index in the command, ID) of the IDs that are handled (and of ``series``)."""
        table = self.h.table
        ids = list(ids)
        if allow_all and (not ids or ids == [BROADCAST_ID]):
            return list(enumerate(table.ids))
        out, seen = [], set()
        for k, dxl_id in enumerate(ids):
            if dxl_id not in table:
                self.warn(f"{what}: ID {dxl_id} is not handled: ignored")
                continue
            model = table.model(dxl_id)
            if series is not None and model.series != series:
                self.warn(f"{what}: ID {dxl_id} is {model.name} (series {model.series}), not {series}: ignored")
                continue
            if dxl_id in seen:
                out = [(kk, ii) for kk, ii in out if ii != dxl_id]  # a repeated ID: the last value wins
            seen.add(dxl_id)
            out.append((k, dxl_id))
        return out

    def finite(self, what: str, field: str, dxl_id: int, value: float) -> bool:
        if isinstance(value, float) and not math.isfinite(value):
            self.warn(f"{what}: ID {dxl_id} '{field}' = {value} refused (not a finite number)")
            return False
        return True

    def to_pulses(self, what: str, field: str, dxl_id: int, item: str, value: float) -> int | None:
        """Units -> pulses for one servo, clamped to its limits with a warning; None if refused."""
        model = self.h.table.model(dxl_id)
        if not model.has(item):
            self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: '{field}' ignored")
            return None
        return self._clamp(what, field, dxl_id, item, value, int(units.unit_to_pulse([model], item, [value])[0]))

    def _clamp(self, what: str, field: str, dxl_id: int, item: str, value: float, pulses: int) -> int:
        model = self.h.table.model(dxl_id)
        lo, hi = self._limits(dxl_id, item, model)
        if lo is not None and hi is not None and not lo <= pulses <= hi:
            clamped = min(max(pulses, lo), hi)
            shown = float(units.pulse_to_unit([model], item, [clamped])[0])
            self.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} is beyond the servo's limit: clamped to {shown:g}")
            pulses = clamped
        return pulses

    def _limits(self, dxl_id: int, item: str, model: Model) -> tuple[int | None, int | None]:
        spec = model.item(item)
        lo, hi = spec.min_raw, spec.max_raw
        if item == "goal_position":
            mode = self.h.mode(dxl_id)
            if mode == "position":
                a, b = self._value(dxl_id, "min_position_limit"), self._value(dxl_id, "max_position_limit")
                if a is not None and b is not None and a <= b:
                    return a, b
            if model.series == "X":
                # X multi-turn goals: -1,048,575..1,048,575 pulses (±256 turns) in the e-Manual
                return (max(lo, -X_MULTI_TURN_GOAL), min(hi, X_MULTI_TURN_GOAL)) if mode != "position" else (lo, hi)
            turns = int(round(MAX_ROTATION * 360.0 / model.position_deg_per_pulse))
            return max(lo, -turns), min(hi, turns)
        bound_item = MAGNITUDE_LIMIT.get(item)
        if bound_item is not None and model.has(bound_item):
            bound = self._value(dxl_id, bound_item)
            if bound is not None and bound > 0:
                if item.startswith("goal_"):
                    return max(lo, -bound), min(hi, bound)
                return 0, min(hi, bound)
        if item.startswith("profile_"):
            return 0, hi
        return lo, hi

    def _allowed(self, last_times: dict[int, float], param: str, dxl_id: int, action: str) -> bool:
        """Rate limit per servo (``param`` seconds apart); warns and refuses when too soon."""
        now, interval = time.monotonic(), self.h.config[param]
        last = last_times.get(dxl_id)
        if last is not None and now - last < interval:
            self.warn(f"{action} refused: the last one was {now - last:.2f}s ago ({param}={interval:g})")
            return False
        last_times[dxl_id] = now
        return True

    def _value(self, dxl_id: int, item: str) -> int | None:
        value = self.h.table.value(item, dxl_id)
        return value if value is not None else self.h.read_item(dxl_id, item)

    # ============================================================== goals and control
    def _goal_writes(self, what: str, targets: list[tuple[int, int]], fields: Fields,
                     item_of: Callable[[str, int], str | None], rotation: Sequence | None = None) -> None:
        writes: dict[str, dict[int, int]] = {}
        table = self.h.table
        for field, values in fields.items():
            if field == "rotation":
                continue
            # one vectorised conversion per item, then each servo's limits
            by_item: dict[str, list[tuple[int, float]]] = {}
            for k, dxl_id in targets:
                item = item_of(field, dxl_id)
                if item is None:
                    continue
                value = values[k]
                if not self.finite(what, field, dxl_id, value):
                    continue
                if field == "position_deg" and rotation is not None:
                    if rotation[k] is None:
                        continue  # its rotation was refused: without the turns it would go elsewhere
                    value = float(value) + 360.0 * float(rotation[k])
                model = table.model(dxl_id)
                if not model.has(item):
                    self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: '{field}' ignored")
                    continue
                by_item.setdefault(item, []).append((dxl_id, float(value)))
            for item, rows in by_item.items():
                pulses = units.unit_to_pulse([table.model(i) for i, _ in rows], item, [v for _, v in rows])
                for (dxl_id, value), raw in zip(rows, pulses.tolist()):
                    writes.setdefault(item, {})[dxl_id] = self._clamp(what, field, dxl_id, item, value, raw)
        # rotation given alone: turns on top of the present goal's angle
        if rotation is not None and "position_deg" not in fields:
            for k, dxl_id in targets:
                if rotation[k] is None:
                    continue
                current = self.h.table.units("goal_position")[self.h.table.index[dxl_id]]
                base = 0.0 if not math.isfinite(current) else math.fmod(current, 360.0)
                pulses = self.to_pulses(what, "rotation", dxl_id, "goal_position", base + 360.0 * float(rotation[k]))
                if pulses is not None:
                    writes.setdefault("goal_position", {})[dxl_id] = pulses
        if writes:
            self.h.pending.put_many(writes.items())
            if self.h.config["verbose/write_goal"]:
                self.log.info(f"{what}: pending {', '.join(f'{i}={v}' for i, v in writes.items())}")

    def _checked_rotation(self, what: str, targets: list[tuple[int, int]], fields: Fields) -> list | None:
        """Rotations clamped to ±256 turns; None for a refused one (NaN/inf), which refuses that
        ID's position goal too."""
        rotation = fields.get("rotation")
        if rotation is None:
            return None
        rotation = list(rotation)
        for k, dxl_id in targets:
            r = rotation[k]
            if not math.isfinite(r):
                self.warn(f"{what}: ID {dxl_id} 'rotation' = {r} refused (not a finite number), "
                          "and with it the position goal")
                rotation[k] = None
            elif abs(r) > MAX_ROTATION:
                self.warn(f"{what}: ID {dxl_id} 'rotation' = {r:g} is beyond ±{MAX_ROTATION:g}: clamped")
                rotation[k] = math.copysign(MAX_ROTATION, r)
        return rotation

    def _control(self, series: str, control: str, ids: list[int], fields: Fields) -> None:
        what = f"{series.lower()}/{control}"
        mode = CONTROL_MODES[control]
        targets = self.known_ids(ids, what, series)
        if not targets:
            return
        # goals meant for another mode are not written where the mode change was refused or failed
        targets = [(k, dxl_id) for k, dxl_id in targets
                   if self.h.mode(dxl_id) == mode or self.change_mode(dxl_id, mode, what)]
        if not targets:
            return

        def item_of(field: str, dxl_id: int) -> str | None:
            model = self.h.table.model(dxl_id)
            if series == "PRO" and field == "velocity_deg_s" and mode in ("position", "ex_position"):
                # Pro position control: the speed of the move (old Pro: goal velocity, -RA: profile)
                return "profile_velocity" if model.has("profile_velocity") else "goal_velocity"
            return GOAL_FIELDS.get(field)
        self._goal_writes(what, targets, fields, item_of, self._checked_rotation(what, targets, fields))

    def _goal(self, ids: list[int], fields: Fields, what: str) -> None:
        targets = self.known_ids(ids, what)
        if targets:
            self._goal_writes(what, targets, fields, lambda f, _i: GOAL_FIELDS.get(f))

    def change_mode(self, dxl_id: int, mode: str, what: str) -> bool:
        """Torque off -> operating mode -> goals restored -> torque back as it was (rate-limited)."""
        model = self.h.table.model(dxl_id)
        if mode not in SERIES_MODES[model.series]:
            self.warn(f"{what}: ID {dxl_id} ({model.name}) has no '{mode}' mode: ignored")
            return False
        if not self._allowed(self._last_mode_change, "mode_change_interval_sec", dxl_id,
                             f"{what}: ID {dxl_id} mode change to '{mode}'"):
            return False
        keep = {item: self._value(dxl_id, item) for item in ("goal_current", "profile_velocity", "profile_acceleration")
                if model.has(item)}
        torque = self._value(dxl_id, "torque_enable")
        if torque:
            self.h.torque_off(dxl_id)
        ok = self.h.write_item(dxl_id, "operating_mode", OPERATING_MODES[mode])
        for item, value in keep.items():
            if value is not None:
                self.h.write_item(dxl_id, item, value)
        if torque:
            self.h.torque_on(dxl_id)
        if ok:
            self.log.info(f"ID {dxl_id}: operating mode -> {mode}")
        else:
            self.warn(f"{what}: ID {dxl_id} mode change to '{mode}' failed: {self.h.bus.last_failure}")
        return ok

    # ============================================================== status, gains, limits
    def _status(self, ids: list[int], fields: Fields, what: str) -> None:
        table = self.h.table
        if "ping" in fields:  # add/remove first: the other fields may concern an added ID
            for k, dxl_id in enumerate(ids):
                if fields["ping"][k]:
                    if dxl_id not in table:
                        self.h.add_id(dxl_id)
                else:
                    self.h.remove_id(dxl_id)
        if not set(fields) - {"ping"}:
            return  # nothing else to do: an ID just removed is no "unknown ID"
        targets = self.known_ids(ids, what)
        for k, dxl_id in targets:
            if "error" in fields:
                self.clear_error(dxl_id, keep_rotation=bool(fields["error"][k]), what=what)
            if "mode" in fields:
                mode = str(fields["mode"][k]).strip()
                if mode not in OPERATING_MODES:
                    self.warn(f"{what}: ID {dxl_id} unknown mode '{mode}' (known: {', '.join(OPERATING_MODES)})")
                elif self.h.mode(dxl_id) != mode:
                    self.change_mode(dxl_id, mode, what)
            if "torque" in fields:
                if fields["torque"][k]:
                    self.torque_on(dxl_id)
                else:
                    self.h.torque_off(dxl_id)

    def torque_on(self, dxl_id: int) -> None:
        """Torque on as asked by a command: safely if it is off; a servo whose torque is already on
        keeps its goals (the safe torque on would make them the present state and stop it)."""
        if self.h.read_item(dxl_id, "torque_enable") != 1:
            self.h.torque_on(dxl_id)

    def clear_error(self, dxl_id: int, keep_rotation: bool, what: str) -> bool:
        """Reboot to clear a hardware error; with ``keep_rotation`` the multi-turn position survives
        through the homing offset. Torque comes back on if it was on, or if the error's shutdown
        switched it off (then the error, not the user, turned it off)."""
        if not self._allowed(self._last_clear, "clear_error_interval_sec", dxl_id, f"{what}: ID {dxl_id} error clear"):
            return False
        model = self.h.table.model(dxl_id)
        torque = self._value(dxl_id, "torque_enable")
        error = self.h.read_item(dxl_id, "hardware_error_status") or 0
        shutdown = self._value(dxl_id, "shutdown")
        torque = bool(torque) or bool(error & (0xFF if shutdown is None else shutdown))
        before = self.h.read_item(dxl_id, "present_position")
        offset = self.h.read_item(dxl_id, "homing_offset")
        if not self.h.reboot(dxl_id):
            self.warn(f"{what}: ID {dxl_id} reboot failed: {self.h.bus.last_failure}")
            return False
        self.h.read_item(dxl_id, "torque_enable")
        self.h.read_item(dxl_id, "hardware_error_status")
        if keep_rotation and before is not None and offset is not None:
            after = self.h.read_item(dxl_id, "present_position")
            if after is not None:
                per_turn = int(round(360.0 / model.position_deg_per_pulse))
                turns = int(round((before - after) / per_turn))
                if turns:
                    self.h.write_eeprom(dxl_id, "homing_offset", offset + turns * per_turn)
                    self.h.read_item(dxl_id, "present_position")
        if torque:
            self.h.torque_on(dxl_id)
        self.log.info(f"ID {dxl_id}: hardware error cleared ({'turns kept' if keep_rotation else 'turns reset'})")
        return True

    def _gain(self, ids: list[int], fields: Fields, what: str) -> None:
        writes: dict[str, dict[int, int]] = {}
        for field, values in fields.items():
            item = GAIN_FIELDS.get(field)
            if item is None:
                continue
            for k, dxl_id in self.known_ids(ids, what):
                model = self.h.table.model(dxl_id)
                if not model.has(item):
                    self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
                    continue
                value, top = int(values[k]), model.item(item).max_raw
                if value > top:
                    self.warn(f"{what}: ID {dxl_id} '{field}' = {value} is beyond {top}: clamped")
                    value = top
                writes.setdefault(item, {})[dxl_id] = value
        if writes:
            self.h.pending.put_many(writes.items())

    def _limit(self, ids: list[int], fields: Fields, what: str) -> None:
        for k, dxl_id in self.known_ids(ids, what):
            model = self.h.table.model(dxl_id)
            values: dict[str, int] = {}
            for field, item in LIMIT_FIELDS.items():
                if field not in fields:
                    continue
                value = fields[field][k]
                if not self.finite(what, field, dxl_id, value):
                    continue
                if not model.has(item):
                    self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: ignored")
                    continue
                if value < 0 and item not in ("max_position_limit", "min_position_limit"):
                    self.warn(f"{what}: ID {dxl_id} '{field}' = {value:g} refused (negative)")
                    continue
                values[item] = int(units.unit_to_pulse([model], item, [float(value)])[0])
            lo = values.get("min_position_limit", self.h.table.value("min_position_limit", dxl_id))
            hi = values.get("max_position_limit", self.h.table.value("max_position_limit", dxl_id))
            if lo is not None and hi is not None and lo > hi:
                self.warn(f"{what}: ID {dxl_id} min position limit above max: position limits ignored")
                values.pop("min_position_limit", None)
                values.pop("max_position_limit", None)
            for item, pulses in values.items():
                if not self.h.write_eeprom(dxl_id, item, pulses):
                    self.warn(f"{what}: ID {dxl_id} writing {item} failed: {self.h.bus.last_failure}")
            if values and self.h.config["verbose/write_limit"]:
                self.log.info(f"{what}: ID {dxl_id} limits written: {values}")

    # ============================================================== shortcut
    def _shortcut(self, action: str, ids: list[int]) -> None:
        what = f"shortcut {action}"
        if action == "add_id":
            for dxl_id in ids:
                if dxl_id not in self.h.table:
                    self.h.add_id(dxl_id)
            return
        if action == "remove_id":
            for dxl_id in (list(self.h.table.ids) if not ids or ids == [BROADCAST_ID] else ids):
                self.h.remove_id(dxl_id)
            return
        for _, dxl_id in self.known_ids(ids, what, allow_all=True):
            if action == "clear_error":
                self.clear_error(dxl_id, keep_rotation=True, what=what)
            elif action == "torque_on":
                self.torque_on(dxl_id)
            elif action in ("torque_off", "disable"):
                self.h.torque_off(dxl_id)
            elif action == "enable":
                self.h.write_item(dxl_id, "torque_enable", 1)
            elif action == "reboot":
                self.h.reboot(dxl_id)
                self.h.read_item(dxl_id, "torque_enable")
            elif action == "reset_offset":
                self.h.write_eeprom(dxl_id, "homing_offset", 0)
