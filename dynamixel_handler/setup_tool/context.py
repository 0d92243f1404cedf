"""What every verb gets: the open bus, the output, the common options and the confirmation."""
from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TextIO

from ..bus import DynamixelBus
from .errors import StepFailed
from .output import Output
from .servo import Servo, locate

__all__ = ["Context"]


@dataclass
class Context:
    bus: DynamixelBus
    out: Output
    #: ``--baud`` was given (else single-servo verbs look for the servo at every rate)
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

    def servo(self, dxl_id: int) -> Servo:
        return locate(self.bus, dxl_id, self.baud_given)

    def line(self) -> str | None:
        """The next line the user types (None at the end of input)."""
        got = self.stdin.readline()
        return got if got else None

    def confirm(self, question: str) -> None:
        """Ask before an EEPROM write (``--yes`` skips it); StepFailed when not confirmed."""
        if self.yes:
            return
        self.out.say(f"{question} [y/N]")
        answer = self.line()
        if answer is None or answer.strip().lower() not in ("y", "yes"):
            raise StepFailed(f"not confirmed: nothing written ({'no answer on stdin; ' if answer is None else ''}"
                             "--yes confirms without asking)")
