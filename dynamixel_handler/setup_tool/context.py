"""What every verb gets: the open bus, the output, the common options and the confirmation."""
from __future__ import annotations

import sys
from dataclasses import dataclass, field
from typing import Sequence, TextIO

from ..bus import DynamixelBus
from .errors import StepFailed
from .find import Found, Placed, Search
from .output import Output
from .servo import Servo
from .values import servo_doc

__all__ = ["Context", "confirm"]


@dataclass
class Context:
    bus: DynamixelBus
    out: Output
    #: one ``--baud`` rate was given (else single-servo verbs look for the servo at every rate, or at
    #: those of a ``--baud`` list)
    baud_given: bool
    #: ``--yes``: no confirmation asked
    yes: bool
    stdin: TextIO = sys.stdin
    #: ``--torque-off``: a servo's torque may go off for an EEPROM write or a reboot (else refused)
    torque_off: bool = False
    #: ``--force``: values that lower a protection are written (else refused)
    force: bool = False
    #: ``--raw``: values are register values (else a value of an item with a unit needs its unit)
    raw: bool = False
    #: ``--protocol``: "2", "1" or "both" (None: an ID is looked for in both, every servo in 2.0)
    protocols: str | None = None
    #: a ``--baud`` list (``57600,1M``): the rates a search looks at, in this order (empty: every rate)
    rates: Sequence[int] = ()
    #: the one search every verb uses (one ``--baud`` rate: that rate only; a list: those; else every rate)
    search: Search = field(init=False)

    def __post_init__(self) -> None:
        self.search = Search(self.bus, self.baud_given, self.protocols, self.rates)

    def servo(self, dxl_id: int) -> Servo:
        """The servo at ``dxl_id`` (at any rate unless ``--baud``), the bus at its rate. The JSON
        document starts with it in the shape of a servo in every verb (``id``, ``model``,
        ``model_number``, ``baudrate``; a verb that moves it updates ``id`` or ``baudrate``)."""
        servo = self.search.one(dxl_id)
        self.out.document.update(servo_doc(servo.dxl_id, servo.model, self.bus.baudrate))
        return servo

    def servos(self, ids: Sequence[int] | None) -> Found:
        """The servos at ``ids`` (None: every servo on the bus, StepFailed when none answers); each
        ID that answers nowhere is said in one line and listed in ``missing``."""
        if ids is None:
            return self.search.every()
        found = self.search.find(ids)
        for dxl_id in found.missing:
            self.out.error(found.why_missing(dxl_id))
        return found

    def at(self, placed: Placed) -> Servo:
        """The bus at ``placed``'s rate; its servo."""
        if self.bus.baudrate != placed.baudrate:
            self.bus.set_baudrate(placed.baudrate)
        return placed.servo

    def fail_if_missing(self, found: Found, done: str) -> None:
        """StepFailed (exit 1) naming the IDs that answered nowhere, after the others were ``done``."""
        if found.missing:
            ids = ", ".join(map(str, found.missing))
            raise StepFailed(f"{len(found.missing)} of {len(found.missing) + len(found.placed)} servo(s) not found "
                             f"(ID {ids}); {done}")

    def line(self) -> str | None:
        """The next line the user types (None at the end of input)."""
        got = self.stdin.readline()
        return got if got else None

    def confirm(self, question: str) -> None:
        """Ask before an EEPROM write (``--yes`` skips it); StepFailed when not confirmed."""
        confirm(self.out, self.stdin, self.yes, question)


def confirm(out: Output, stdin: TextIO, yes: bool, question: str) -> None:
    """Ask ``question`` (unless ``yes``); StepFailed when the answer is not yes."""
    if yes:
        return
    out.say(f"{question} [y/N]")
    answer = stdin.readline() or None
    if answer is None or answer.strip().lower() not in ("y", "yes"):
        raise StepFailed(f"not confirmed: nothing written ({'no answer on stdin; ' if answer is None else ''}"
                         "--yes confirms without asking)")
