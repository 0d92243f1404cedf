"""One servo as the tool sees it: its model from the control table, the protocol it answers (2.0, or
1.0: an AX, RX, DX, EX or MX (1.0) model, or a 2.0 model set to Protocol Type 1), reads and writes
by item name in that protocol, its mode (a Protocol 1.0 model's from its Angle Limits), and the
checked write every verb uses (only when the value differs; EEPROM with torque off and torque
restored where the model needs it; read back and verified; a failure says which state the servo
is left in)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from ..bus import DynamixelBus, Failure, Result
from ..bus.ops import Instruction, Ping, Read, Write
from ..control_table import Item, Model
from ..protocol.framers import FRAMERS
from ..units import decode, encode
from .errors import StepFailed
from .items import find_item, show_value
from .per_protocol import tool_protocol
from .protocol1 import error_names1, mode1
from .safety import checked_write

__all__ = ["Servo", "connect", "SEARCH_ORDER"]

#: where unboxed servos are, then the other rates (9600 last: slow and rare)
SEARCH_ORDER = (57600, 1_000_000, 115200, 2_000_000, 3_000_000, 4_000_000, 4_500_000, 6_000_000,
                10_500_000, 9600)


@dataclass
class Servo:
    bus: DynamixelBus
    dxl_id: int
    model: Model
    #: the protocol it answers: 2, or 1 (a Protocol 1.0 model, or a 2.0 model set to Protocol Type 1)
    protocol: int = 2
    #: the error byte of the latest status it answered (in Protocol 1.0: its state, the error bits)
    status_error: int = field(default=0, compare=False)

    def execute(self, op: Instruction) -> Result[Any]:
        """``op`` on its bus; the error byte of the status that came back is kept (``status_error``)."""
        got = self.bus.execute(op)
        if got.error is not None:
            self.status_error = got.error
        return got

    @property
    def who(self) -> str:
        return f"ID {self.dxl_id} ({self.model.name})"

    @property
    def modes_by_limits(self) -> bool:
        """No Operating Mode register: its Angle Limits select its mode (an AX, RX, DX, EX or MX (1.0)
        model, ``Model.mode_select``)."""
        return self.model.mode_select is not None

    def item(self, name: str) -> Item:
        return find_item(self.model, name)

    def read(self, name: str) -> int:
        item = self.item(name)
        got = self.execute(Read(self.dxl_id, item.address, item.size, protocol=self.protocol))
        if got.value is None:
            raise StepFailed(f"{self.who}: reading {item.name} failed: {_cause(got.why)}")
        return int(decode(item, got.value)[0])

    def read_block(self, first: Item, last: Item) -> bytes:
        """The bytes from ``first`` to the end of ``last`` in one read."""
        size = last.address + last.size - first.address
        got = self.execute(Read(self.dxl_id, first.address, size, protocol=self.protocol))
        if got.value is None:
            raise StepFailed(f"{self.who}: reading {first.name}..{last.name} failed: {_cause(got.why)}")
        return bytes(got.value)

    def write(self, name: str, raw: int) -> None:
        item = self.item(name)
        done = self.execute(Write(self.dxl_id, item.address, encode(item, raw), protocol=self.protocol))
        if not done and not self._answers_reads_only(done.failure):
            raise StepFailed(f"{self.who}: writing {item.name} = {show_value(self.model, item, raw)} "
                             f"failed: {_cause(done.why)}")

    def _answers_reads_only(self, failure: Failure | None) -> bool:
        """Whether a write that got no status went to a servo at Status Return Level 1 (it answers
        reads and pings only) of a protocol whose writes are then taken as sent (Protocol 1.0,
        ``ToolProtocol.quiet_writes``); every checked write reads it back."""
        if not tool_protocol(self.protocol).quiet_writes or failure is not Failure.NO_REPLY \
                or not self.model.has("status_return_level"):
            return False
        item = self.model.item("status_return_level")
        got = self.execute(Read(self.dxl_id, item.address, item.size, protocol=self.protocol))
        return got.value is not None and got.value[0] < 2

    def torque_on(self) -> bool:
        return self.read("torque_enable") == 1

    def mode(self) -> str | None:
        """The mode it is in by name (None: the model has no modes): the Operating Mode register, or
        on a Protocol 1.0 model the Angle Limits (both 0: velocity, both 4095 on MX: ex_position)
        and Torque Control Mode Enable (current)."""
        model = self.model
        if model.has("operating_mode"):
            return model.mode_name(self.read("operating_mode"))
        if not (self.modes_by_limits and model.has("min_position_limit")):
            return None
        control = self.read("torque_control_mode_enable") if model.has("torque_control_mode_enable") else 0
        return mode1(model, self.read("min_position_limit"), self.read("max_position_limit"), control)

    def status_errors(self) -> list[str]:
        """The error bits of its latest status packet by name where its protocol's status error byte
        carries its state (Protocol 1.0); [] in Protocol 2.0, whose servos report them in Hardware
        Error Status."""
        if not FRAMERS[self.protocol].state_in_error_byte:
            return []
        return error_names1(self.status_error)

    def set_checked(self, name: str, raw: int, after: Callable[[], Servo] | None = None,
                    torque_off: bool = False) -> bool:
        """Write ``raw`` to the item if it differs, as one critical step (:func:`.safety.checked_write`):
        an EEPROM item on a servo with torque on is refused unless ``torque_off``; read back (on the
        servo ``after`` returns: an ID or baud rate change). True if written."""
        return checked_write(self, name, raw, torque_off, after)

    def torque_on_in_place(self) -> None:
        """Torque on without a jump, as the handler does: the goal of the servo's mode first set to
        where it is (position modes, clipped to the limits in position mode) or to rest (0)."""
        model = self.model
        mode = self.mode()
        if mode in ("position", "ex_position", "cur_position") and model.has("goal_position"):
            goal = self.read("present_position")
            if mode == "position" and model.has("min_position_limit") and model.has("max_position_limit"):
                goal = min(max(goal, self.read("min_position_limit")), self.read("max_position_limit"))
            self.write("goal_position", goal)
        else:
            rest = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}.get(mode or "")
            if rest is not None and model.has(rest):
                self.write(rest, 0)
        self.write("torque_enable", 1)


def _cause(failure: str) -> str:
    """The bus's reason without its own prefix ("read ID 3 @64x1: no reply ..." -> "no reply ...")."""
    return failure.split(": ", 1)[1] if ": " in failure else failure or "no reply"


def connect(bus: DynamixelBus, dxl_id: int, protocol: int = 2) -> Servo:
    """The servo at ``dxl_id`` on the bus at its present rate, in ``protocol``; StepFailed when it
    does not answer or its model is not one the control table knows."""
    got = bus.execute(Ping(dxl_id, protocol=protocol))
    if got.value is None:
        raise StepFailed(f"ID {dxl_id}: no servo answers{tool_protocol(protocol).note} at "
                         f"{bus.baudrate} bps ({_cause(got.why)})")
    try:
        return Servo(bus, dxl_id, tool_protocol(protocol).model_for(got.value), protocol)
    except KeyError:
        raise StepFailed(f"ID {dxl_id}: model number {got.value} is not in the control table; "
                         "the tool only sets up models the handler knows") from None
