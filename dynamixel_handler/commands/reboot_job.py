"""``dynamixel/reboot``: the servos in hardware error rebooted, each checked and reported.

A job of the ``moves.Book``, carried out by the loop thread after a step: the servos whose hardware
error status (or error code) says error are cleared one after the other with the core's
``ClearError`` (a reboot, waiting for the servo to answer again; the ``servos`` block's RAM items
and the profiles written again; torque back on if it was on or if the error's shutdown turned it
off), then their error is read again. Servos without an error are not touched. It moves nothing,
so an engaged E-stop does not end it."""
from __future__ import annotations

import numpy as np

from ..servo import error_state
from .move_checks import DONE, ERROR
from .moves import Book, Job

__all__ = ["RebootJob"]


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
