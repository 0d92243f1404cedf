"""The checks a Protocol 1.0 firmware makes on a write (ROBOTIS e-Manual, the AX-12A / MX-28 / MX-64
pages and "Protocol 1.0"), in the engine's error codes (``firmware.Firmware.protocol1_bits`` turns them
into status bits):

* A write is refused whole (Data Range Error: the Range Error bit) when it touches a read-only item,
  runs past the table, holds a value outside an item's range (an unknown Baud Rate value, an ID above
  253, a gain above 254...) or writes EEPROM while Lock is 1. Single bytes of a two-byte item may be
  written (the table is bytes), and so may bytes no item owns.
* A Goal Position outside the Angle Limits in Joint Mode is refused (Data Limit Error: the Angle
  Limit Error bit).
* EEPROM items may be written with torque on (a host switches Wheel and Joint Mode on the fly).
"""
from __future__ import annotations

from dynamixel_handler.control_table import Item
from dynamixel_handler.control_table._protocol1 import mode_of

from ..protocol import servo as p
from .registers import Registers

_LIMITS = ("min_position_limit", "max_position_limit")


def check_write(registers: Registers, address: int, data: bytes,
                latched: bool = False) -> tuple[int, list[tuple[Item, int]]]:
    """(error, [(item, value)]): every item the write touches as its whole bytes after the write
    (unsigned, so the bytes are stored as written), and each byte no item owns."""
    file = registers.file
    end = address + len(data)
    if not data or address < 0 or end > len(file.regs):
        return p.ERR_DATA_RANGE, []
    if address < file.eeprom_end and registers.get("lock"):
        return p.ERR_DATA_RANGE, []
    new = bytearray(file.regs)
    new[address:end] = data
    changes: list[tuple[Item, int]] = []
    for it in file.items:
        if it.address < end and address < it.address + it.size:
            error = _item_error(registers, it, new)
            if error:
                return error, []
            raw = new[it.address:it.address + it.size]
            changes.append((Item(it.name, it.address, it.size, False, it.eeprom), int.from_bytes(raw, "little")))
    for a in range(address, end):
        if file.owner[a] is None:
            changes.append((Item(f"byte_{a}", a, 1, False, a < file.eeprom_end), new[a]))
    return p.ERR_NONE, changes


def _item_error(registers: Registers, it: Item, new: bytearray) -> int:
    """The error a touched item's new bytes get (ERR_NONE: none)."""
    raw = new[it.address:it.address + it.size]
    if it.name in registers.model.read_only:
        return p.ERR_DATA_RANGE
    if it.direction_bit and int.from_bytes(raw, "little") >> (it.direction_bit + 1):
        return p.ERR_DATA_RANGE  # a speed or torque beyond 0..2047
    return _value_error(registers, it.name, it.from_bytes(raw), new)


def _value_error(registers: Registers, name: str, value: int, new: bytearray) -> int:
    model = registers.model
    lo, hi = model.ranges.get(name, (-(1 << 31), 1 << 31))
    if not lo <= value <= hi or (name == "baud_rate" and value not in registers.baud_rates):
        return p.ERR_DATA_RANGE
    if name == "goal_position":
        cw, ccw = (model.item(n).from_bytes(new[model.item(n).address:model.item(n).address + 2]) for n in _LIMITS)
        if mode_of(cw, ccw) == "position" and not cw <= value <= ccw:
            return p.ERR_DATA_LIMIT
    return p.ERR_NONE
