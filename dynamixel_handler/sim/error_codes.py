"""How a virtual servo's error registers act: Hardware Error Status bits against the Shutdown mask
(X, P, PRO), or one error code (Y, ``ServoFamily.error_codes``: which codes switch torque off,
which the Error Clear packet clears)."""
from __future__ import annotations

from dynamixel_handler.control_table import Model

from ..protocol import servo as p
from .registers import Registers

#: the registers that hold a servo's errors (a model has one of them)
ERROR_ITEMS = ("hardware_error_status", "error_code")


def switches_torque_off(registers: Registers, name: str, value: int) -> bool:
    """An error register that became ``value`` switches torque off (and latches until cleared)."""
    codes = registers.model.family.error_codes
    if codes is not None and name == codes.item:
        code = codes.code(value)
        return code is not None and code.torque_off
    return bool(value & registers.get("shutdown", 0xFF))


def alert(registers: Registers) -> bool:
    """An error is held: the status packet carries the alert bit."""
    return any(registers.get(name, 0) for name in ERROR_ITEMS)


def holds(registers: Registers) -> bool:
    """Y: an error that keeps torque on holds the servo: goal writes are refused while torque is
    on (e-Manual "Error Code(153)", the Hold column: following error, bus watchdog, over speed,
    position limit reached)."""
    codes = registers.model.family.error_codes
    if codes is None or registers.peek("torque_enable") != 1:
        return False
    code = codes.code(registers.peek(codes.item))
    return code is not None and code.hold


def is_error_clear(model: Model, params: bytes) -> bool:
    """A Clear instruction's parameters ask for the error clear of a model that has one."""
    codes = model.family.error_codes
    return codes is not None and params == codes.clear_params


def watchdog_written(registers: Registers, value: int) -> None:
    """Bus Watchdog written: 0 ends a trip, and on Y the Bus Watchdog Error code with it."""
    codes = registers.model.family.error_codes
    if value == 0 and codes is not None and registers.peek(codes.item) == codes.watchdog:
        registers.poke(codes.item, 0)


def clear(registers: Registers) -> int:
    """The Error Clear (Y, e-Manual "Error Clear Packet"): a clearable code goes (a tripped bus
    watchdog with it); one it cannot clear stays and the servo answers Result Fail."""
    codes = registers.model.family.error_codes
    assert codes is not None
    code = codes.code(registers.peek(codes.item))
    if code is not None and not code.clearable:
        return p.ERR_RESULT_FAIL
    registers.poke(codes.item, 0)
    if registers.get("bus_watchdog", 0) < 0:
        registers.poke("bus_watchdog", 0)
    return p.ERR_NONE
