"""A virtual servo's error state, as its family reports it (``ServoFamily.error_in_status``; made for
each servo by its ``firmware.Firmware``):

* ``RegisterErrors`` (Protocol 2.0 families): Hardware Error Status bits against the Shutdown mask, or
  one Y error code (``error_codes``); a shutdown error switches torque off and is latched until the
  error is cleared (a reboot, or Y's Error Clear); every status carries the alert bit meanwhile.
* ``StatusErrors`` (Protocol 1.0 families): the conditions of the moment are bits of every status's
  error byte: input voltage (Present Voltage outside the voltage limits), overheating (Present
  Temperature above its limit) and overload (the load beyond Torque Limit, latched). A condition
  whose bit is set in Shutdown writes Torque Limit 0 (no output); writing Torque Limit again, once the
  cause is gone, brings the output back (there is no reboot instruction on AX and RX).
"""
from __future__ import annotations

from typing import Protocol

from dynamixel_handler.control_table._protocol1 import OUTPUT_FULL_SCALE

from ..protocol import protocol1 as p1
from . import error_codes
from .motion import Motor
from .registers import Registers


class Shaft(Protocol):
    """What an error state stops and measures (``dynamics.Dynamics``)."""

    motor: Motor

    def load_share(self) -> float: ...
    def refresh(self, now: float) -> None: ...


class ErrorState(Protocol):
    #: a shutdown error holds: Torque Enable 1 is refused
    latched: bool

    def check(self, now: float) -> None: ...
    def in_status(self) -> int: ...
    def alert(self) -> bool: ...
    def set(self, item: str, value: int) -> None: ...
    def host_wrote(self, name: str, value: int) -> None: ...
    def power_cycle(self) -> None: ...


class RegisterErrors:
    """Errors in an error register (see the module)."""

    def __init__(self, registers: Registers, dynamics: Shaft) -> None:
        self._r, self._d = registers, dynamics
        self.latched = False

    def check(self, now: float) -> None:
        """Nothing to check as time goes: an error is set (``set``), not measured."""

    def in_status(self) -> int:
        return 0

    def alert(self) -> bool:
        return error_codes.alert(self._r)

    def set(self, item: str, value: int) -> None:
        """An error register became ``value`` (a test's or the CLI's fault): torque drops if it is a
        shutdown error; 0 ends the latch."""
        if item not in error_codes.ERROR_ITEMS:
            return
        if error_codes.switches_torque_off(self._r, item, value):
            self.latched = True
            self._r.poke("torque_enable", 0)
            self._d.motor.stop()
        elif value == 0:
            self.latched = False

    def host_wrote(self, name: str, value: int) -> None:
        """A host's write changes no error (the error registers are read-only)."""

    def power_cycle(self) -> None:
        self.latched = False


class StatusErrors:
    """Errors in the status error byte (see the module)."""

    latched = False

    def __init__(self, registers: Registers, dynamics: Shaft) -> None:
        self._r, self._d = registers, dynamics
        self._overloaded = False

    def check(self, now: float) -> None:
        """Overload (the load beyond Torque Limit) latches; a condition set in Shutdown cuts the
        output (Torque Limit 0)."""
        r = self._r
        limit = r.peek("torque_limit")
        if limit > 0 and r.peek("torque_enable") and abs(self._d.load_share()) * OUTPUT_FULL_SCALE > limit:
            self._overloaded = True
        if self.in_status() & r.peek("shutdown") and limit > 0:
            r.poke("torque_limit", 0)
            self._d.motor.stop()
            self._d.refresh(now)

    def in_status(self) -> int:
        r = self._r
        bits = p1.ERR_OVERLOAD if self._overloaded else 0
        if not r.peek("min_voltage_limit") <= r.peek("present_input_voltage") <= r.peek("max_voltage_limit"):
            bits |= p1.ERR_VOLTAGE
        if r.peek("present_temperature") > r.peek("temperature_limit"):
            bits |= p1.ERR_OVERHEATING
        return bits

    def alert(self) -> bool:
        return False

    def set(self, item: str, value: int) -> None:
        """A value set by a test: the conditions follow from the present values."""

    def host_wrote(self, name: str, value: int) -> None:
        if name == "torque_limit" and value > 0:
            self._overloaded = False  # the Protocol 1.0 way out of a shutdown

    def power_cycle(self) -> None:
        self._overloaded = False

