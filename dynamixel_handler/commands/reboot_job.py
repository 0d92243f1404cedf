"""``dynamixel/reboot``: the servos in hardware error rebooted, each checked and reported;
``dynamixel/reboot_servos``: the servos named rebooted (``RebootServosJob``), healthy ones too.

A job of the ``moves.Book``, carried out by the loop thread after a step: the servos whose hardware
error status (or error code) says error are cleared one after the other with the core's
``ClearError`` (a reboot, waiting for the servo to answer again; the ``servos`` block's RAM items
and the profiles written again; torque back on if it was on or if the error's shutdown turned it
off), then their error is read again. Servos without an error are not touched. It moves nothing,
so an engaged E-stop does not end it.

``RebootServosJob`` reboots exactly the servos named, one a loop step, with the set-up tool's rule:
a reboot turns torque off, so a servo holding torque is rebooted only with ``torque_off`` consent,
and its torque comes back on with goal := present (refused while the E-stop is engaged: it stays
off, and the answer says so). Every servo is checked first: one refused (not handled, torque on
without consent, its torque not read) and none is rebooted. The core's reboot sets the servo up
again (the ``servos`` block's RAM items and the profiles written back, the watchdog armed)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..servo import error_state
from .move_checks import DONE, ERROR
from .moves import Book, Job

__all__ = ["RebootJob", "RebootServosJob", "Rebooted", "TORQUE_REFUSAL"]

#: why a servo holding torque is not rebooted without consent (the set-up tool's words)
TORQUE_REFUSAL = ("torque is on and a reboot turns it off, which lets go of the load it holds: give torque_off to "
                  "reboot it and turn torque back on with the goal where it is")


class RebootJob(Job):
    moves = False

    def __init__(self, answer_by: float) -> None:
        super().__init__("reboot", [], answer_by)

    def advance(self, book: Book, now: float) -> None:
        if not book.claim(self):
            return
        h = book.h
        failing = error_state.in_error(h.table) if len(h.table) else np.zeros(0, dtype=bool)
        self.ids = [int(h.table.ids[int(pos)]) for pos in np.flatnonzero(failing)]
        if not self.ids:
            book.finish(self, DONE, "no servo has a hardware error: none rebooted")
            return
        lines, ok = [], True
        for dxl_id in self.ids:
            line, cleared = self._clear(book, dxl_id)
            lines.append(line)
            ok = ok and cleared
        book.finish(self, DONE if ok else ERROR, "; ".join(lines))

    @staticmethod
    def _clear(book: Book, dxl_id: int) -> tuple[str, bool]:
        """One servo rebooted and read again: (its line, whether its error is gone)."""
        h = book.h
        model = h.model(dxl_id)
        who = f"ID {dxl_id} ({model.name})"
        done = h.core.clear_error(dxl_id, keep_rotation=True, what="reboot")
        if not done:
            return f"{who}: not rebooted: {done.failure}", False
        error = h.read_item(dxl_id, error_state.error_item(model))
        if error is None:
            return f"{who}: rebooted, but it does not answer", False
        if error_state.is_error(model, error):
            return f"{who}: rebooted, the error is still there ({error_state.describe(model, error)})", False
        torque = h.read_item(dxl_id, "torque_enable")
        return f"{who}: rebooted, error gone, torque {'on' if torque else 'off'}", True


@dataclass(frozen=True)
class Rebooted:
    """One named servo's outcome: rebooted (and answering), its torque after, or why not ("")."""

    dxl_id: int
    rebooted: bool
    torque_on: bool
    error: str = ""


class RebootServosJob(Job):
    """The servos ``ids`` rebooted, one a step, after all of them were checked."""

    moves = False

    def __init__(self, ids: list[int], torque_off: bool, answer_by: float) -> None:
        super().__init__("reboot_servos", list(ids), answer_by)
        self.torque_off = torque_off
        self.results: list[Rebooted] = []
        #: each servo's torque before its reboot (None until every servo is checked)
        self._torque: dict[int, bool] | None = None

    def advance(self, book: Book, now: float) -> None:
        if not book.claim(self):
            return
        h = book.h
        if h.figures().device_lost:
            book.finish(self, ERROR, f"the bus device is gone (reconnecting): {self._so_far()}")
            return
        if self._torque is None:
            self._check(book)
            return
        dxl_id = self.ids[len(self.results)]
        self.results.append(self._reboot(book, dxl_id))
        if len(self.results) == len(self.ids):
            failed = [r for r in self.results if r.error]
            lines = "; ".join(_line(book, r) for r in self.results)
            book.finish(self, ERROR if failed else DONE, lines)

    def _check(self, book: Book) -> None:
        """Every servo's torque read; a refusal anywhere: none rebooted (the job ends)."""
        h = book.h
        torque: dict[int, bool] = {}
        why: dict[int, str] = {}
        for dxl_id in self.ids:
            if not h.handles(dxl_id):
                why[dxl_id] = "not handled by this node"
                continue
            value = h.read_item(dxl_id, "torque_enable") if h.model(dxl_id).has("torque_enable") else 0
            if value is None:
                why[dxl_id] = "no answer to the torque read: not rebooted"
            elif value and not self.torque_off:
                why[dxl_id] = TORQUE_REFUSAL
            torque[dxl_id] = bool(value)
        if why:
            others = "not rebooted: another servo named was refused"
            self.results = [Rebooted(i, False, torque.get(i, False), why.get(i, others)) for i in self.ids]
            first = next(i for i in self.ids if i in why)
            book.finish(self, ERROR, f"refused, nothing rebooted: ID {first}: {why[first]}")
            return
        self._torque = torque

    def _reboot(self, book: Book, dxl_id: int) -> Rebooted:
        """One servo rebooted (the core waits until it answers and sets it up again), its torque
        back on if it was on."""
        assert self._torque is not None
        h = book.h
        done = h.core.reboot(dxl_id, keep_turns=True)  # a multi-turn joint keeps its position
        error = "" if done else f"not rebooted: {done.failure}"
        torque = h.read_item(dxl_id, "torque_enable") if h.model(dxl_id).has("torque_enable") else 0
        if torque is None:
            return Rebooted(dxl_id, bool(done), False, error or "rebooted, but it does not answer")
        if self._torque[dxl_id] and not torque:  # it was on: the owner's consent was to a reboot, not to a drop
            back = h.core.torque_on(dxl_id, "reboot_servos")
            torque = h.read_item(dxl_id, "torque_enable") if back else 0
            if not back:
                error = error or f"rebooted; torque stays off: {back.failure}"
        return Rebooted(dxl_id, bool(done), bool(torque), error)

    def overdue(self) -> tuple[int, str]:
        return ERROR, f"the bus loop did not finish '{self.what}' in time: {self._so_far()}"

    def _so_far(self) -> str:
        done = [r.dxl_id for r in self.results if r.rebooted]
        return f"ID {', '.join(map(str, done))} rebooted before" if done else "none rebooted"


def _line(book: Book, r: Rebooted) -> str:
    who = f"ID {r.dxl_id} ({book.h.model(r.dxl_id).name})"
    return f"{who}: {r.error}" if r.error else f"{who}: rebooted, torque {'on' if r.torque_on else 'off'}"
