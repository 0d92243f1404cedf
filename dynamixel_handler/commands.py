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
from .extra_commands import apply_extra
from .logs import Throttle, cut, some_ids
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
#: X series: Profile Velocity and Profile Acceleration registers take 0..32767 (e-Manual); on the
#: P series they are bounded by Velocity Limit and Acceleration Limit instead
X_PROFILE_MAX = 32767
#: modes that need a current sensor (XL430 / XC430 / 2XL430 have none: Current Limit absent)
CURRENT_MODES = frozenset({"current", "cur_position"})
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
        # a warning repeated within a second (same cause, same servo) is counted, not logged
        self.throttle = Throttle(self.log.warning)

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
        self._queue(what, lambda: apply_extra(self, list(ids), fields, what))

    def shortcut(self, command: str, ids: Sequence[int]) -> None:
        action = SHORTCUTS.get(command.strip())
        if action is None:
            self.warn(f"shortcut: unknown command '{cut(command)}' (known: {', '.join(SHORTCUTS)})")
            return
        self._queue(f"shortcut {command}", lambda: self._shortcut(action, list(ids)))

    def _queue(self, what: str, op: Callable[[], None]) -> None:
        if self.verbose:
            self.log.info(f"command accepted: {what}")
        self.h.queue(what, op)

    # ============================================================== helpers (loop thread)
    def warn(self, msg: str) -> None:
        """A warning about a command; the same one within a second is only counted (``Throttle``)."""
        self.throttle(msg)

    def known_ids(self, ids: Iterable[int], what: str, series: str | None = None,
                  allow_all: bool = False) -> list[tuple[int, int]]:
        """(index in the command, ID) of the IDs that are handled (and of ``series``)."""
        table = self.h.table
        ids = list(ids)
        if allow_all and (not ids or ids == [BROADCAST_ID]):
            return list(enumerate(table.ids))
        last: dict[int, int] = {}  # ID -> index of its last entry (a repeated ID: the last value wins)
        unknown, other = [], []
        for k, dxl_id in enumerate(ids):
            if dxl_id not in table:
                unknown.append(dxl_id)
                continue
            if series is not None and table.model(dxl_id).series != series:
                other.append(dxl_id)
                continue
            last.pop(dxl_id, None)
            last[dxl_id] = k
        # one line per kind of bad ID per message, naming a few of them
        if len(unknown) == 1:
            self.warn(f"{what}: ID {unknown[0]} is not handled: ignored")
        elif unknown:
            self.warn(f"{what}: IDs {some_ids(unknown)} are not handled: ignored")
        if len(other) == 1:
            model = table.model(other[0])
            self.warn(f"{what}: ID {other[0]} is {model.name} (series {model.series}), not {series}: ignored")
        elif other:
            self.warn(f"{what}: IDs {some_ids(other)} are not of series {series}: ignored")
        return [(k, dxl_id) for dxl_id, k in last.items()]

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
            self.warn(f"ID {dxl_id} ({model.name}) '{field}' = {value:g} is beyond the servo's limit: clamped to {shown:g}")
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
        if item.startswith("profile_") and model.series == "X":
            bound_item = None  # X: the register's own range, not Velocity Limit
        if bound_item is not None and model.has(bound_item):
            bound = self._value(dxl_id, bound_item)
            if bound is not None and bound > 0:
                if item.startswith("goal_"):
                    return max(lo, -bound), min(hi, bound)
                return 0, min(hi, bound)
        if item.startswith("profile_"):
            return 0, min(hi, X_PROFILE_MAX) if model.series == "X" else hi
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
        # rotation given alone: the missing position_deg is 0, so the goal is 360 deg x rotation
        if rotation is not None and "position_deg" not in fields:
            for k, dxl_id in targets:
                if rotation[k] is None:
                    continue
                pulses = self.to_pulses(what, "rotation", dxl_id, "goal_position", 360.0 * float(rotation[k]))
                if pulses is not None:
                    writes.setdefault("goal_position", {})[dxl_id] = pulses
        if writes:
            self.h.clear_tripped(sorted({i for values in writes.values() for i in values}))
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
                self.warn(f"ID {dxl_id} 'rotation' = {r:g} is beyond ±{MAX_ROTATION:g}: clamped")
                rotation[k] = math.copysign(MAX_ROTATION, r)
        return rotation

    def _control(self, series: str, control: str, ids: list[int], fields: Fields) -> None:
        what = f"{series.lower()}/{control}"
        mode = CONTROL_MODES[control]
        targets = self.known_ids(ids, what, series)
        if not targets:
            return
        ready = []
        for k, dxl_id in targets:
            if self.h.mode(dxl_id) == mode:
                self.h.deferred.pop(dxl_id, None)  # a later request wins over a waiting mode change
                ready.append((k, dxl_id))
                continue
            outcome = self.change_mode(dxl_id, mode, what)
            if outcome == "done":
                ready.append((k, dxl_id))
            elif outcome == "later":
                # the mode change and the goals that came with it wait for mode_change_interval_sec
                one = {f: [v[k]] for f, v in fields.items()}
                self._defer(dxl_id, "mode_change_interval_sec", f"{what}: ID {dxl_id} (deferred)",
                            lambda i=dxl_id, one=one: self._control(series, control, [i], one))
            # "refused"/"failed": goals meant for another mode are not written
        targets = ready
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

    def change_mode(self, dxl_id: int, mode: str, what: str) -> str:
        """Torque off -> operating mode -> goals and profiles written back -> torque back as it
        was (safely: goal := present state) -> bus watchdog as the new mode needs.
        "done", "refused" (the servo has no such mode), "failed" (the bus), or "later": the last
        change was less than mode_change_interval_sec ago (the caller defers the request)."""
        model = self.h.table.model(dxl_id)
        if mode not in SERIES_MODES[model.series]:
            self.warn(f"{what}: ID {dxl_id} ({model.name}) has no '{mode}' mode: ignored")
            return "refused"
        if mode in CURRENT_MODES and not model.has("current_limit"):
            self.warn(f"{what}: ID {dxl_id} ({model.name}) has no current sensor, so no '{mode}' mode: ignored")
            return "refused"
        if self._wait_left(self._last_mode_change, "mode_change_interval_sec", dxl_id) > 0:
            return "later"
        self._last_mode_change[dxl_id] = time.monotonic()
        old = self.h.mode(dxl_id)
        # RAM items the firmware resets on a mode change; the old mode's own goal is left out (it
        # would mean something else now) and the new mode's goal is set by the safe torque on
        items = ["goal_pwm", "goal_current", "goal_velocity", "profile_velocity", "profile_acceleration"]
        own = {"pwm": "goal_pwm", "current": "goal_current", "velocity": "goal_velocity"}.get(old or "")
        keep = {item: self._value(dxl_id, item) for item in items if model.has(item) and item != own}
        torque = self.h.read_item(dxl_id, "torque_enable")
        if torque:
            self.h.torque_off(dxl_id)
        ok = self.h.write_item(dxl_id, "operating_mode", OPERATING_MODES[mode])
        for item, value in keep.items():
            if value is not None:
                self.h.write_item(dxl_id, item, value)
        if torque:
            self.h.torque_on(dxl_id)
        self.h.arm_after_ops(dxl_id)
        if ok:
            self.log.info(f"ID {dxl_id}: operating mode -> {mode}")
        else:
            self.warn(f"{what}: ID {dxl_id} mode change to '{mode}' failed: {self.h.bus.last_failure}")
        return "done" if ok else "failed"

    def _wait_left(self, last_times: dict[int, float], param: str, dxl_id: int) -> float:
        """Seconds until ``param`` seconds have passed since the servo's last such action (0: now)."""
        last = last_times.get(dxl_id)
        if last is None:
            return 0.0
        return max(0.0, last + self.h.config[param] - time.monotonic())

    def _defer(self, dxl_id: int, param: str, what: str, op: Callable[[], None]) -> None:
        """Run ``op`` for this servo once ``param`` allows it; a later request replaces it."""
        left = self._wait_left(self._last_mode_change, param, dxl_id)
        if dxl_id not in self.h.deferred:
            self.log.info(f"{what}: the last mode change was less than {param}="
                          f"{self.h.config[param]:g}s ago: applied in {left:.2f}s")
        self.h.deferred[dxl_id] = (time.monotonic() + left, what, op)

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
                    self.warn(f"{what}: ID {dxl_id} unknown mode '{cut(mode)}' (known: {', '.join(OPERATING_MODES)})")
                elif self.h.mode(dxl_id) == mode:
                    self.h.deferred.pop(dxl_id, None)
                elif self.change_mode(dxl_id, mode, what) == "later":
                    self._defer(dxl_id, "mode_change_interval_sec", f"{what}: ID {dxl_id} (deferred)",
                                lambda i=dxl_id, m=mode: self._status([i], {"mode": [m]}, what))
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
        model = self.h.table.model(dxl_id)
        error = self.h.read_item(dxl_id, "hardware_error_status")
        if error is None:
            self.warn(f"{what}: ID {dxl_id} did not answer the hardware error read: not rebooted")
            return False
        if error == 0:
            self.log.debug(f"{what}: ID {dxl_id} has no hardware error: nothing to clear (not rebooted)")
            return True
        if not self._allowed(self._last_clear, "clear_error_interval_sec", dxl_id, f"{what}: ID {dxl_id} error clear"):
            return False
        torque = self._value(dxl_id, "torque_enable")
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
                    self.warn(f"ID {dxl_id} ({model.name}) '{field}' = {value} is beyond {top}: clamped to {top}")
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
