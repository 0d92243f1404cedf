"""What the set-up tool does differently for the servos of each protocol: one value per framer
(``ToolProtocol``, keyed by the framers of ``protocol.framers.FRAMERS``), asked through
``tool_protocol(protocol)``; what is the wire's (Sync Read, the status error byte, the reset's
option, the ping's parameters) the framer itself answers.

For a servo it is the value of the protocol it answers (``servo.protocol``: a Protocol 1.0 model, or
a 2.0 model set to Protocol Type 1, answers 1.0); for what a model's firmware does (EEPROM with
torque on, its baud table in words) the value of its family's protocol (``model.protocol``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Mapping

from ..bus import DYNAMIXEL_BAUDRATES
from ..control_table import Item, Model, model_by_number, protocol1_model_by_number
from ..protocol import protocol1 as p1
from ..protocol.framers import FRAMERS, PROTOCOL1, PROTOCOL2, Framer
from .protocol1 import rates1, type_1_warning

__all__ = ["ToolProtocol", "tool_protocol", "rates_text"]


def rates_text(rates: Iterable[int]) -> str:
    """``57,600, 1,000,000``: rates in ascending order."""
    return ", ".join(f"{bps:,}" for bps in sorted(rates))


def _baud_formula(by_bps: Mapping[int, int]) -> str:
    """A Protocol 1.0 model's baud table: 2,000,000/(n+1), and the rates of it the bus opens."""
    return (f"2,000,000/(n+1) bps at Baud Rate n, {min(by_bps):,} .. {max(by_bps):,} bps; those this tool reaches: "
            f"{rates_text(b for b in by_bps if b in DYNAMIXEL_BAUDRATES)}")


def _never(error: int) -> bool:
    return False


def _instruction_error(error: int) -> bool:
    """A Protocol 1.0 status with the Instruction Error bit: the model does not know the instruction."""
    return bool(error & p1.ERR_INSTRUCTION)


@dataclass(frozen=True)
class ToolProtocol:
    """The set-up tool's rules for the servos of one protocol."""

    # ------------------------------------------------------------ a servo that answers it
    #: what a line about a servo that answers it adds ("": Protocol 2.0, the usual one)
    note: str
    #: the style of its servos' rows in ``scan``'s table (None: the plain one)
    row_style: str | None
    #: where the model of the number a servo answered with is looked up, in order (a 2.0 servo set
    #: to Protocol Type 1 answers Protocol 1.0 with its own number)
    lookups: tuple[Callable[[int], Model], ...]
    #: the rates its servos can be at that the bus opens (None: every one the bus opens)
    rates: Callable[[], tuple[int, ...]] | None
    #: a write that got no status is taken as sent when the servo's Status Return Level is 1 (it
    #: answers reads and pings only); every checked write reads it back
    quiet_writes: bool
    #: a reboot answered with this status error byte: the model has no Reboot instruction
    no_reboot: Callable[[int], bool]
    #: why ``calibrate --homing-offset`` refuses a servo that answers it ("": it does not)
    homing_refused: str
    #: what ``set`` and ``restore`` warn when Protocol Type switches a servo to it (None: nothing)
    switch_warning: Callable[[str, int], str] | None
    # ------------------------------------------------------------ a model whose family speaks it
    #: the items written with torque off (None: the EEPROM area)
    torque_off_items: tuple[str, ...] | None
    #: why a write of ``{item}`` with torque on is refused
    torque_rule: str
    #: the caption of ``info``'s EEPROM table
    eeprom_caption: str
    #: the rates a baud table (bps -> Baud Rate value) gives, in words
    baud_text: Callable[[Mapping[int, int]], str]

    def model_for(self, number: int) -> Model:
        """The model of a servo that answered with ``number``; KeyError when the control table has none."""
        for lookup in self.lookups[:-1]:
            try:
                return lookup(number)
            except KeyError:
                pass
        return self.lookups[-1](number)

    def may_be_at(self, bps: int) -> bool:
        """Whether one of its servos can be at ``bps``."""
        return self.rates is None or bps in self.rates()

    def needs_torque_off(self, item: Item) -> bool:
        """Whether a model of it takes ``item`` only with torque off."""
        return item.eeprom if self.torque_off_items is None else item.name in self.torque_off_items


_PROTOCOL2 = ToolProtocol(
    note="", row_style=None, lookups=(model_by_number,), rates=None, quiet_writes=False, no_reboot=_never,
    homing_refused="", switch_warning=None, torque_off_items=None,
    torque_rule="{item} (EEPROM) is written only with torque off, which lets go of the load it holds",
    eeprom_caption="EEPROM (written with torque off)", baud_text=rates_text)

#: a Protocol 1.0 model takes EEPROM writes with torque on (it keeps holding its load), but its
#: Angle Limits switch its mode: those are written with torque off like an Operating Mode
_PROTOCOL1 = ToolProtocol(
    note=" Protocol 1.0", row_style="yellow", lookups=(protocol1_model_by_number, model_by_number), rates=rates1,
    quiet_writes=True, no_reboot=_instruction_error, homing_refused="it answers Protocol 1.0",
    switch_warning=type_1_warning, torque_off_items=("min_position_limit", "max_position_limit"),
    torque_rule="{item} switches its mode (wheel, joint, multi-turn), which it would do holding its load",
    eeprom_caption="EEPROM (a Protocol 1.0 model takes it with torque on)", baud_text=_baud_formula)

_BY_FRAMER: dict[Framer, ToolProtocol] = {PROTOCOL2: _PROTOCOL2, PROTOCOL1: _PROTOCOL1}


def tool_protocol(protocol: int) -> ToolProtocol:
    """The tool's rules for the servos of ``protocol`` (a servo's, or a model's ``model.protocol``)."""
    return _BY_FRAMER[FRAMERS[protocol]]
