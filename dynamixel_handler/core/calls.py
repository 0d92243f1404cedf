"""What the command side may ask of the core in the loop thread: one typed method per thing.

A command (``dynamixel_handler.commands``) runs in the loop thread (its request was taken from the
queue, ``intake.Intake``) and asks for what it checked through these methods; each hands the call
to the part that does it and answers with an ``Answer`` (True in a condition when done). Nothing
here is queued: only what crosses threads goes on the queue. The E-stop's gate is here, once: while
it is engaged, a call that would move a servo (goals, a mode change, torque on, a RAM write of a
goal or of torque on) is refused with one line a second per kind."""
from __future__ import annotations

from typing import Mapping

from ..servo.table import ServoTable
from .deferred import Deferred
from .e_stop import GOAL_ITEMS, EStop
from .reboots import Reboots
from .request_types import DONE, Answer, Later, answer
from .requests import Requests
from .servo_io import ServoIO
from .servo_setup import ServoSetup
from .startup import Startup
from .watchdog import Watchdog


class CoreCalls:
    """The core's typed surface for the command side (loop thread only)."""

    def __init__(self, table: ServoTable, io: ServoIO, work: Deferred, requests: Requests, reboots: Reboots,
                 startup: Startup, watchdog: Watchdog, e_stop: EStop, setup: ServoSetup) -> None:
        self._table, self._io, self._work, self._requests = table, io, work, requests
        self._reboots, self._startup, self._watchdog, self._e_stop = reboots, startup, watchdog, e_stop
        self._setup = setup

    # ---------------------------------------------------------------- what moves a servo (gated)
    def set_goals(self, writes: Mapping[str, Mapping[int, int]], what: str = "goals") -> Answer:
        """Goal values {item: {ID: pulses}} for the next sync writes (a tripped watchdog cleared
        first); refused while the E-stop is engaged when a goal is among them (gains and profiles
        alone move nothing)."""
        if any(item in GOAL_ITEMS for item in writes):
            refused = self._e_stop.refusal(what)
            if refused is not None:
                return refused
        self._requests.put_goals(writes)
        return DONE

    def change_mode(self, dxl_id: int, mode: str, what: str = "mode") -> Answer:
        """The servo to ``mode`` (the caller checked that its model has it); LATER says why it waits."""
        refused = self._e_stop.refusal(what)
        return refused if refused is not None else self._requests.change_mode(dxl_id, mode, what)

    def torque_on(self, dxl_id: int, what: str = "torque on") -> Answer:
        """Torque on without a jump (goals := present state first)."""
        refused = self._e_stop.refusal(what)
        return refused if refused is not None else answer(self._io.torque_on(dxl_id))

    def write_item(self, dxl_id: int, item: str, pulses: int, what: str = "write") -> Answer:
        """One RAM item of one servo, written now."""
        if item in GOAL_ITEMS or (item == "torque_enable" and pulses != 0):
            refused = self._e_stop.refusal(what)
            if refused is not None:
                return refused
        return answer(self._io.write_item(dxl_id, item, pulses))

    # ---------------------------------------------------------------- the rest
    def defer_mode_change(self, dxl_id: int, why: Later, then: object, what: str = "mode (deferred)") -> Answer:
        """A mode change that answered LATER: ``then`` (a queued request) runs again once it may."""
        self._requests.defer_mode_change(dxl_id, why, then, what)
        return DONE

    def cancel_deferred(self, dxl_id: int) -> Answer:
        """A later request for the servo wins over a mode change waiting for it."""
        self._work.cancel(dxl_id)
        return DONE

    def clear_error(self, dxl_id: int, keep_rotation: bool, what: str = "clear error") -> Answer:
        """A hardware error cleared (the family's way: reboot, error clear instruction or Torque
        Limit written back); turns kept with ``keep_rotation``."""
        return self._requests.clear_error(dxl_id, keep_rotation, what)

    def torque_off(self, dxl_id: int) -> Answer:
        return answer(self._io.torque_off(dxl_id))

    def write_eeprom(self, dxl_id: int, item: str, pulses: int) -> Answer:
        """One EEPROM item of one servo, spared and coalesced (``Deferred.write_eeprom``)."""
        return answer(self._work.write_eeprom(dxl_id, item, pulses))

    def write_eeprom_many(self, dxl_id: int, values: dict[str, int]) -> Answer:
        """EEPROM items of one servo in one torque-off window (a load held sags once, not once an
        item), each spared and coalesced as ``write_eeprom``'s (``Deferred.write_eeprom_many``)."""
        return answer(self._work.write_eeprom_many(dxl_id, values))

    def reboot(self, dxl_id: int, keep_turns: bool = False) -> Answer:
        """A reboot, at most once per clear_error_interval_sec per servo. ``keep_turns``: a servo in a
        multi-turn mode gets the whole turns the boot took back through its Homing Offset, as after
        a power loss (``ServoSetup.give_back_turns``: not where its servos block sets the offset)."""
        before = self._io.read_item(dxl_id, "present_position") if keep_turns else None
        done = self._reboots.reboot(dxl_id)
        if done and before is not None:
            self._setup.give_back_turns(dxl_id, before)
        return answer(done)

    def add_servo(self, dxl_id: int) -> Answer:
        """Ping the ID and handle it if it answers with a model of a used series."""
        return answer(self._startup.add_id(dxl_id), f"ID {dxl_id} not added")

    def remove_servo(self, dxl_id: int) -> Answer:
        """Stop handling the servo now."""
        self._table.remove(dxl_id)
        return DONE

    def want_handled(self, dxl_id: int, handled: bool) -> Answer:
        """add_id (True) or remove_id (False), applied once a loop (the last request of a loop wins)."""
        self._startup.want_handled(dxl_id, handled)
        return DONE

    def set_user_watchdog(self, dxl_id: int, pulses: int) -> Answer:
        """The bus watchdog time the user asked for (0: off), kept whatever the mode."""
        self._watchdog.set_user(dxl_id, pulses)
        return DONE
