"""``dynamixel/get_items`` and ``dynamixel/set_items``: any control-table item of the handled servos
read or written through the loop, by the set-up tool's item names and with its checks.

A job of the ``moves.Book``, carried out by the loop thread after its steps, a few bus transactions
a step (``READS_PER_STEP`` reads, or one servo's writes), so the loop keeps its rate while a long
request is answered over several loops. A write is checked as the set-up tool checks it
(``setup_tool.checks``: the model's e-Manual range, min below max for a limit pair, a value that
lowers a protection only with ``force``); an EEPROM item of a servo holding torque needs
``torque_off`` (the core's EEPROM write turns torque off for it and back on with goal := present).
Every servo is checked before anything is written, and one refused item means nothing is written
to any servo, as the set-up tool writes nothing when one value is refused. Each item is read back.
Goals, torque, the mode (the command topics do those, safely) and what changes the bus under the
node (ID, baud rate, protocol) are refused."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

from ..control_table import Item, Model
from ..setup_tool.checks import needed, problems
from ..setup_tool.errors import BadArguments
from ..setup_tool.items import find_item, parse_value, to_unit, unit_of
from .move_checks import DONE, ERROR
from .moves import Book, Job

if TYPE_CHECKING:
    from ..core.api import ServoAccess

__all__ = ["NOT_HERE", "READS_PER_STEP", "ItemResult", "ItemsJob", "Writes"]

#: reads done in one loop step (a read is one transaction: about a millisecond at 1 Mbps)
READS_PER_STEP = 6
#: items set_items does not write, and where they are changed
NOT_HERE = {
    **{goal: "a goal: give it on the command topics or move_to (checked, clamped, E-stop aware)"
       for goal in ("goal_position", "goal_velocity", "goal_current", "goal_pwm")},
    "torque_enable": "torque: dynamixel/set_torque or the command topics switch it safely (goal := present first)",
    "operating_mode": "the mode: the command topics' mode field switches it with its goals handled",
    "id": "it changes the bus under the node: dynamixel_handler_setup set-id with the node stopped",
    "baud_rate": "it changes the bus under the node: dynamixel_handler_setup set-baud with the node stopped",
    "protocol_type": "it changes the bus under the node: dynamixel_handler_setup set with the node stopped",
}


@dataclass(frozen=True)
class Writes:
    """What set_items asks: one value per item, or one per servo and item; raw or in units."""

    values: tuple[float, ...]
    raw: bool = False
    force: bool = False
    torque_off: bool = False


@dataclass(frozen=True)
class ItemResult:
    dxl_id: int
    item: str
    raw: int | None
    value: float            #: in ``unit`` (NaN: none, or not read)
    unit: str
    error: str = ""


class ItemsJob(Job):
    """Reads (``writes`` None) or writes and reads back the ``items`` of the servos ``ids``."""

    moves = False

    def __init__(self, ids: Sequence[int], items: Sequence[str], writes: Writes | None, answer_by: float) -> None:
        super().__init__("set_items" if writes is not None else "get_items", list(ids), answer_by)
        self.items = list(items)
        self.writes = writes
        self.results: list[ItemResult] = []
        self._next = 0  # the next (servo, item) to read, or the next servo to check, then to write
        #: each servo's registers and refusals, as checked before anything is written
        self._checked: list[tuple[dict[str, int], dict[str, str]]] = []

    def value_of(self, k_servo: int, k_item: int) -> float:
        assert self.writes is not None
        values = self.writes.values
        return values[k_item] if len(values) == len(self.items) else values[k_servo * len(self.items) + k_item]

    def advance(self, book: Book, now: float) -> None:
        if not book.claim(self):
            return
        if book.h.figures().device_lost:
            book.finish(self, ERROR, f"the bus device is gone (reconnecting): {self._done_so_far()}")
            return
        if self._step(book.h):
            failed = [r for r in self.results if r.error]
            verb = "read" if self.writes is None else "written"
            message = (f"{len(self.results)} item(s) {verb}" if not failed else
                       f"{len(self.results) - len(failed)} of {len(self.results)} item(s) {verb}; first refusal: "
                       f"ID {failed[0].dxl_id} {failed[0].item}: {failed[0].error}")
            book.finish(self, DONE if not failed else ERROR, message)

    def _step(self, h: ServoAccess) -> bool:
        """This step's share: READS_PER_STEP reads, or one servo's writes; True when all is done."""
        if self.writes is not None:
            return self._write_step(h)
        total = len(self.ids) * len(self.items)
        for k in range(self._next, min(total, self._next + READS_PER_STEP)):
            self.results.append(read_one(h, self.ids[k // len(self.items)], self.items[k % len(self.items)]))
        self._next = min(total, self._next + READS_PER_STEP)
        return self._next >= total

    def overdue(self) -> tuple[int, str]:
        return ERROR, f"the bus loop did not finish '{self.what}' in time: {self._done_so_far()}"

    def _done_so_far(self) -> str:
        return f"{len(self.results)} item(s) done before" if self.results else "nothing was done"

    def _write_step(self, h: ServoAccess) -> bool:
        """Every servo checked first, one a step; then, if none was refused, each written and read
        back, one a step (a refusal anywhere: nothing written, as the set-up tool's ``set``)."""
        n = len(self.ids)
        if self._next < n:
            self._checked.append(self._check_servo(h, self._next))
            self._next += 1
            if self._next == n and any(why for _, why in self._checked):
                self.results = [r for k in range(n) for r in self._refusals(k)]
                return True
            return False
        k = self._next - n
        self.results += self._write_servo(h, k, self._checked[k][0])
        self._next += 1
        return self._next >= 2 * n

    def _check_servo(self, h: ServoAccess, k: int) -> tuple[dict[str, int], dict[str, str]]:
        """One servo's values as registers and why any may not be written ({} when none)."""
        assert self.writes is not None
        dxl_id = self.ids[k]
        if not h.handles(dxl_id):
            return {}, {name: "not handled by this node" for name in self.items}
        model = h.model(dxl_id)
        asked: dict[str, int] = {}
        why: dict[str, str] = {}
        for j, name in enumerate(self.items):
            try:
                asked[name] = _raw_of(model, name, self.value_of(k, j), self.writes.raw)
            except BadArguments as err:
                why[name] = str(err).split(": ", 1)[-1]
        why.update(_problems(h, dxl_id, model, asked, self.writes))
        return asked, why

    def _refusals(self, k: int) -> list[ItemResult]:
        why = self._checked[k][1]
        others = ("not written: another item of this servo was refused" if why else
                  "not written: an item of another servo was refused")
        return [_refused(self.ids[k], name, why.get(name, others)) for name in self.items]

    def _write_servo(self, h: ServoAccess, k: int, asked: dict[str, int]) -> list[ItemResult]:
        """One servo's items (all checked) written and read back: its EEPROM items in one torque-off
        window (a load held sags once, not once an item), then its RAM items."""
        dxl_id = self.ids[k]
        model = h.model(dxl_id)
        why: dict[str, str] = {}
        eeprom = {name: raw for name, raw in asked.items() if model.items[name].eeprom}
        if eeprom and not (done := h.core.write_eeprom_many(dxl_id, eeprom)):
            why.update({name: f"not written: {done.failure}" for name in eeprom})
        for name, raw in asked.items():
            if name not in eeprom and not (done := h.core.write_item(dxl_id, name, raw, what="set_items")):
                why[name] = f"not written: {done.failure}"
        return [_written(h, dxl_id, name, asked[name], why.get(name, "")) for name in self.items]


def read_one(h: ServoAccess, dxl_id: int, name: str) -> ItemResult:
    """One item of one servo read now, in its unit."""
    if not h.handles(dxl_id):
        return _refused(dxl_id, name, "not handled by this node")
    model = h.model(dxl_id)
    try:
        item = find_item(model, name)
    except BadArguments as err:
        return _refused(dxl_id, name, str(err))
    raw = h.read_item(dxl_id, item.name)
    if raw is None:
        return ItemResult(dxl_id, item.name, None, math.nan, unit_of(model, item), "no answer to the read")
    return _result(model, item, dxl_id, raw)


def _result(model: Model, item: Item, dxl_id: int, raw: int, error: str = "") -> ItemResult:
    value = to_unit(model, item, raw)
    return ItemResult(dxl_id, item.name, raw, math.nan if value is None else value, unit_of(model, item), error)


def _refused(dxl_id: int, name: str, why: str) -> ItemResult:
    return ItemResult(dxl_id, name, None, math.nan, "", why)


def _raw_of(model: Model, name: str, value: float, raw: bool) -> int:
    """The register value of ``value`` (in the item's unit, or raw), checked as the set-up tool's
    ``set`` parses it; BadArguments with the reason."""
    item = find_item(model, name)
    if item.name in NOT_HERE:
        raise BadArguments(f"set_items: {item.name} is not set here: {NOT_HERE[item.name]}")
    if not math.isfinite(value):
        raise BadArguments(f"set_items: {value!r} is not a finite number")
    unit = "" if raw else unit_of(model, item)
    text = f"{int(value)}" if (raw or not unit) and value == int(value) else f"{value!r}{unit}"
    return parse_value(model, item, text, "set_items", raw=raw)


def _problems(h: ServoAccess, dxl_id: int, model: Model, asked: dict[str, int], writes: Writes) -> dict[str, str]:
    """Why items of ``asked`` may not be written (the set-up tool's checks; EEPROM with torque on)."""
    why = _checked(h, dxl_id, model, asked, writes.force)
    eeprom = [n for n in asked if model.items[n].eeprom and n not in why]
    if eeprom and not writes.torque_off and h.read_item(dxl_id, "torque_enable"):
        why.update({n: "an EEPROM item, and torque is on: the write turns it off for a moment (the load it holds "
                       "sags); give torque_off to allow it" for n in eeprom})
    return why


def _checked(h: ServoAccess, dxl_id: int, model: Model, asked: dict[str, int], force: bool) -> dict[str, str]:
    """The set-up tool's checks, on the present values they need (read now)."""
    now = {}
    for name in needed(model, asked):
        value = h.read_item(dxl_id, name)
        if value is not None:
            now[name] = value
    found = [p for p in problems(model, asked, now, dxl_id, h.handled_ids) if not (p.forcible and force)]
    return {p.item: p.text + (": give force to write it anyway" if p.forcible else "") for p in found}


def _written(h: ServoAccess, dxl_id: int, name: str, asked: int, error: str) -> ItemResult:
    model = h.model(dxl_id)
    item = model.items[name]
    back = h.read_item(dxl_id, name)
    if back is None:
        return ItemResult(dxl_id, name, None, math.nan, unit_of(model, item), error or "written, but no answer to the "
                          "read back")
    if not error and back != asked:
        error = f"read back {back}, not {asked}" + (" (an EEPROM item written moments ago is written again later: "
                                                    "it spares the EEPROM)" if item.eeprom else "")
    return _result(model, item, dxl_id, back, error)
