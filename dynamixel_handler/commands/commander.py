"""Commands in physical units -> checked requests to the core. ROS-free.

The ROS layer hands each command over as ``(id_list, {field: values})`` with arrays of the wrong
length already dropped (``take_fields``). Everything else happens here, *in the loop thread*
(``Commander`` queues the command as a value, ``command_types``, and takes it back in its ``handle``), so
validation sees a consistent servo table and no callback ever touches the bus: unknown or
wrong-series IDs, NaN/inf, unknown mode strings and out-of-range values are refused or clamped with a
warning that names the ID and the field. What passes goes down as one request value
through the core's narrow interface (``core.api.ServoAccess.core``, typed calls).

Goals and control topics are here; status, gains, limits and shortcuts in ``servo_settings``, the
extra fields in ``extra``. The rules themselves (known IDs, finite values, bounds, clamping) are in
``rules``, once. A goal or control command that none of these checks would touch (every ID handled
once, of the family, in the mode; every value a finite number) is applied by
``fast_path.FastGoals`` with what it checked before kept; the same writes and warnings either way.
"""
from __future__ import annotations

import math
from typing import Any, Callable, ClassVar, Iterable, Mapping, Sequence, assert_never, get_args

from .. import units
from ..control_table import ServoFamily, family_named
from ..core.api import ServoAccess
from ..core.request_types import Answer, Outcome
from ..logs import Throttle, cut, some_ids
from .command_types import CommanderRequest, Control, Extra, Gain, Goal, Limit, Shortcut, Status
from .extra import apply_extra
from .fast_path import FastGoals
from .goal_bounds import TableBounds
from .moving_speed import goal_item, not_fastest
from .paths import CommandPaths
from .rules import Row, Rules, fits
from .servo_settings import SettingsCommands
from .tables import BROADCAST_ID, CONTROL_MODES, CURRENT_MODES, GOAL_FIELDS, MAX_ROTATION, SHORTCUTS

Fields = Mapping[str, Sequence[Any]]


def take_fields(what: str, id_list: Sequence[int], fields: Mapping[str, Sequence[Any]],
                warn: Callable[[str], None]) -> dict[str, list[Any]]:
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


def _warn_bad_ids(warn: Callable[[str], None], h: ServoAccess, what: str, unknown: list[int], other: list[int],
                  family: ServoFamily | None) -> None:
    """One line per kind of bad ID per message, naming a few of them."""
    if len(unknown) == 1:
        warn(f"{what}: ID {unknown[0]} is not handled: ignored")
    elif unknown:
        warn(f"{what}: IDs {some_ids(unknown)} are not handled: ignored")
    series = family.name if family is not None else None
    if len(other) == 1:
        model = h.model(other[0])
        warn(f"{what}: ID {other[0]} is {model.name} (series {model.series}), not {series}: ignored")
    elif other:
        warn(f"{what}: IDs {some_ids(other)} are not of series {series}: ignored")


class Commander(SettingsCommands):
    """Turns commands into checked requests to one core (a ``Handler``)."""

    def __init__(self, handler: ServoAccess, paths: CommandPaths | None = None) -> None:
        self.h = handler
        self.log = handler.log
        self.paths = paths = paths if paths is not None else CommandPaths()
        self.verbose = handler.settings.logs.callback
        # a warning repeated within a second (same cause, same servo) is counted, not logged
        self.throttle = Throttle(self.log.warning)
        self.rules = Rules(handler, self.warn, TableBounds(paths.bounds))
        self.fast = FastGoals(handler, self.rules, paths, self.put_writes)

    TAKES: ClassVar[tuple[type, ...]] = get_args(CommanderRequest)

    def handle(self, request: CommanderRequest) -> None:
        """A queued command, in the loop thread (attached to the intake by who builds the Commander)."""
        match request:
            case Control(family=family, control=control, ids=ids, fields=fields):
                self._control(family, control, ids, fields)
            case Goal(ids=ids, fields=fields, what=what):
                self._goal(ids, fields, what)
            case Gain(ids=ids, fields=fields, what=what):
                self._gain(ids, fields, what)
            case Limit(ids=ids, fields=fields, what=what):
                self._limit(ids, fields, what)
            case Status(ids=ids, fields=fields, what=what):
                self._status(ids, fields, what)
            case Extra(ids=ids, fields=fields, what=what):
                apply_extra(self, ids, fields, what)
            case Shortcut(action=action, ids=ids):
                self._shortcut(action, ids)
            case _:
                assert_never(request)

    # ============================================================== entry points (any thread)
    def control(self, series: str | ServoFamily, control: str, ids: Sequence[int], fields: Fields) -> None:
        """A control topic's command for servos of ``series`` (a family or its name: "X", "P", "PRO")."""
        family = family_named(series)
        self.submit(Control(family, control, list(ids), fields, f"{family.suffix} {control}"))

    def goal(self, ids: Sequence[int], fields: Fields, what: str = "goal") -> None:
        self.submit(Goal(list(ids), fields, what))

    def gain(self, ids: Sequence[int], fields: Fields, what: str = "gain") -> None:
        self.submit(Gain(list(ids), fields, what))

    def limit(self, ids: Sequence[int], fields: Fields, what: str = "limit") -> None:
        self.submit(Limit(list(ids), fields, what))

    def status(self, ids: Sequence[int], fields: Fields, what: str = "status") -> None:
        self.submit(Status(list(ids), fields, what))

    def extra(self, ids: Sequence[int], fields: Fields, what: str = "extra") -> None:
        self.submit(Extra(list(ids), fields, what))

    def shortcut(self, command: str, ids: Sequence[int]) -> None:
        action = SHORTCUTS.get(command.strip())
        if action is None:
            self.warn(f"shortcut: unknown command '{cut(command)}' (known: {', '.join(SHORTCUTS)})")
            return
        self.submit(Shortcut(action, list(ids), f"shortcut {command}"))

    def submit(self, request: CommanderRequest) -> None:
        """A command for the loop thread (any thread), as a value."""
        if self.verbose:
            self.log.info(f"command accepted: {request.what}")
        self.h.submit(request)

    # ============================================================== checks (loop thread)
    def warn(self, msg: str) -> None:
        """A warning about a command; the same one within a second is only counted (``Throttle``)."""
        self.throttle(msg)

    def known_ids(self, ids: Iterable[int], what: str, family: ServoFamily | None = None,
                  allow_all: bool = False) -> list[tuple[int, int]]:
        """(index in the command, ID) of the IDs that are handled (and of ``family``)."""
        h = self.h
        ids = list(ids)
        if allow_all and (not ids or ids == [BROADCAST_ID]):
            return list(enumerate(h.handled_ids))
        plan = self.fast.targets(ids, family)
        if plan is not None:  # every ID handled once and of the series: checked before
            return list(plan.targets)
        last: dict[int, int] = {}  # ID -> index of its last entry (a repeated ID: the last value wins)
        unknown, other = [], []
        for k, dxl_id in enumerate(ids):
            if fits(h, dxl_id, family):
                last.pop(dxl_id, None)
                last[dxl_id] = k
            elif not h.handles(dxl_id):
                unknown.append(dxl_id)
            else:
                other.append(dxl_id)
        _warn_bad_ids(self.warn, self.h, what, unknown, other, family)
        return [(k, dxl_id) for dxl_id, k in last.items()]

    def finite(self, what: str, field: str, dxl_id: int, value: float) -> bool:
        return self.rules.finite(what, field, dxl_id, value)

    def to_pulses(self, what: str, field: str, dxl_id: int, item: str, value: float) -> int | None:
        """Units -> pulses for one servo, clamped to its limits with a warning; None if refused."""
        return self.rules.to_pulses(what, field, dxl_id, item, value)

    def _value(self, dxl_id: int, item: str) -> int | None:
        return self.h.value(dxl_id, item)

    # ============================================================== goals and control
    def _goal_writes(self, what: str, targets: list[tuple[int, int]], fields: Fields,
                     item_of: Callable[[str, int], str | None], rotation: Sequence[Any] | None = None) -> None:
        writes: dict[str, dict[int, int]] = {}
        for field, values in fields.items():
            if field == "rotation":
                continue
            # one vectorised conversion per item, then each servo's limits
            for item, rows in self._goal_rows(what, field, values, targets, item_of, rotation).items():
                pulses = units.unit_to_pulse([self.h.model(i) for i, _ in rows], item, [v for _, v in rows])
                clamped = not_fastest(self.h, self.warn, what, item, rows, self.rules.clamp_rows(what, field, item, rows, pulses))
                writes.setdefault(item, {}).update(zip([i for i, _ in rows], clamped))
        if rotation is not None and "position_deg" not in fields:
            self._rotation_alone(what, targets, rotation, writes)
        self.put_writes(what, writes)

    def put_writes(self, what: str, writes: dict[str, dict[int, int]]) -> None:
        if writes:
            self.h.core.set_goals(writes, what)
            if "goal" in self.h.settings.logs.writes:
                self.log.info(f"{what}: pending {', '.join(f'{i}={v}' for i, v in writes.items())}")

    def _goal_rows(self, what: str, field: str, values: Sequence[Any], targets: list[tuple[int, int]],
                   item_of: Callable[[str, int], str | None], rotation: Sequence[Any] | None) -> dict[str, list[Row]]:
        """The finite values of one field, by the item each servo takes it to: {item: [(ID, value)]}."""
        by_item: dict[str, list[Row]] = {}
        for k, dxl_id in targets:
            item = item_of(field, dxl_id)
            if item is None or not self.finite(what, field, dxl_id, values[k]):
                continue
            value = float(values[k])
            if field == "position_deg" and rotation is not None:
                if rotation[k] is None:
                    continue  # its rotation was refused: without the turns it would go elsewhere
                value += 360.0 * float(rotation[k])
            model = self.h.model(dxl_id)
            if not model.has(item):
                self.warn(f"{what}: ID {dxl_id} ({model.name}) has no {item}: '{field}' ignored")
                continue
            by_item.setdefault(item, []).append((dxl_id, value))
        return by_item

    def _rotation_alone(self, what: str, targets: list[tuple[int, int]], rotation: Sequence[Any],
                        writes: dict[str, dict[int, int]]) -> None:
        """Rotation given without position_deg: the missing position is 0, so the goal is 360 deg x rotation."""
        for k, dxl_id in targets:
            if rotation[k] is None:
                continue
            pulses = self.to_pulses(what, "rotation", dxl_id, "goal_position", 360.0 * float(rotation[k]))
            if pulses is not None:
                writes.setdefault("goal_position", {})[dxl_id] = pulses

    def _checked_rotation(self, what: str, targets: list[tuple[int, int]], fields: Fields) -> list[Any] | None:
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

    def _control(self, family: ServoFamily, control: str, ids: list[int], fields: Fields) -> None:
        what = f"{family.suffix}/{control}"
        mode = CONTROL_MODES[control]
        if self.fast.goals(what, ids, fields, family, mode):
            return
        targets = self._in_mode(family, control, self.known_ids(ids, what, family), fields)
        if not targets:
            return

        def item_of(field: str, dxl_id: int) -> str | None:
            model = self.h.model(dxl_id)  # its own family: XL-320 servos on the X topics take their speed item
            # the speed of the move (old Pro, XL-320: goal velocity; where the model has it, profile velocity)
            return model.family.behaviour.control_speed_item(model, field, mode) or GOAL_FIELDS.get(field)
        self._goal_writes(what, targets, fields, item_of, self._checked_rotation(what, targets, fields))

    def _in_mode(self, family: ServoFamily, control: str, targets: list[tuple[int, int]],
                 fields: Fields) -> list[tuple[int, int]]:
        """The targets in the control's mode, switched to it where needed; a mode change asked for
        too soon waits with its goals (latest wins); goals meant for a mode a servo could not
        take are not written."""
        what = f"{family.suffix}/{control}"
        mode = CONTROL_MODES[control]
        ready = []
        for k, dxl_id in targets:
            if self.h.mode(dxl_id) == mode:
                self.h.core.cancel_deferred(dxl_id)  # a later request wins over a waiting mode change
                ready.append((k, dxl_id))
                continue
            changed = self.change_mode(dxl_id, mode, what)
            if changed.outcome is Outcome.DONE:
                ready.append((k, dxl_id))
            elif changed.later is not None:
                one = {f: [v[k]] for f, v in fields.items()}
                self.h.core.defer_mode_change(dxl_id, changed.later, Control(family, control, [dxl_id], one, what),
                                           f"{what}: ID {dxl_id} (deferred)")
        return ready

    def _goal(self, ids: list[int], fields: Fields, what: str) -> None:
        if self.fast.goals(what, ids, fields):
            return
        targets = self.known_ids(ids, what)
        if targets:
            self._goal_writes(what, targets, fields, lambda field, dxl_id: goal_item(self.h, field, dxl_id))

    def change_mode(self, dxl_id: int, mode: str, what: str) -> Answer:
        """The servo to ``mode`` if its model has it: DONE, REFUSED (no such mode), FAILED (the
        bus) or LATER (too soon after the last change: the caller defers the request). A refusal
        or failure is warned about here."""
        model = self.h.model(dxl_id)
        if mode in CURRENT_MODES and not (model.has("current_limit") or model.has("goal_current")):  # the reason first
            return self.warned(Answer(Outcome.REFUSED, f"{what}: ID {dxl_id} ({model.name}) has no current sensor, "
                                      f"so no '{mode}' mode: ignored"))
        if mode not in model.modes:
            return self.warned(Answer(Outcome.REFUSED, f"{what}: ID {dxl_id} ({model.name}) has no '{mode}' mode: ignored"))
        return self.warned(self.h.core.change_mode(dxl_id, mode, what))

    def warned(self, answer: Answer) -> Answer:
        """A request's answer, its failure (if any) warned about once."""
        if answer.failure:
            self.warn(answer.failure)
        return answer
