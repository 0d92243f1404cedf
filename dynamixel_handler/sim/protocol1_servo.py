"""A Protocol 1.0 servo of the virtual bus: its control table (from ``control_table``), the checks
its firmware makes on a write, its error bits and the shaft behind it (``protocol1_motion``).

What a write does (ROBOTIS e-Manual, the AX-12A / MX-28 / MX-64 pages and "Protocol 1.0"):

* A write is refused whole, with the Range Error bit (0x08), when it touches a read-only item, runs
  past the table, holds a value outside an item's range (an unknown Baud Rate value, an ID above
  253, a gain above 254...) or writes EEPROM while Lock is 1. Single bytes of a two-byte item may
  be written (the table is bytes).
* A Goal Position outside the Angle Limits in Joint Mode is refused with the Angle Limit Error bit
  (0x02).
* The status error byte also carries the conditions of the moment: input voltage (Present Voltage
  outside the voltage limits, bit 0), overheating (Present Temperature above its limit, bit 2) and
  overload (the load beyond Torque Limit, bit 5). A condition whose bit is set in Shutdown writes
  Torque Limit 0 (no output); writing Torque Limit again, once the cause is gone, brings the output
  back (there is no reboot instruction on AX and RX).
* Goal Position is set to Present Position at power on; Torque Enable does not change it.
* EEPROM items may be written with torque on (a host switches Wheel and Joint Mode on the fly).
"""

from __future__ import annotations

import threading
import time
from typing import Callable

from dynamixel_handler.control_table import Item, Model, protocol1_model_by_number
from dynamixel_handler.control_table._protocol1 import actual_bps, mode_of

from ..protocol.protocol1 import (
    ERR_ANGLE_LIMIT,
    ERR_INSTRUCTION,
    ERR_OVERHEATING,
    ERR_OVERLOAD,
    ERR_RANGE,
    ERR_VOLTAGE,
)
from .protocol1_motion import Shaft1
from .registers import RegisterFile, Registers

ERR_ANGLE, ERR_OVERHEAT = ERR_ANGLE_LIMIT, ERR_OVERHEATING
BAUD_TOLERANCE = 0.03
#: Firmware Version a virtual servo reports (the pages leave it blank): representative numbers,
#: MX from v41 (Realtime Tick needs v40 / v41)
FIRMWARE = {"AX": 24, "RX": 24, "DX": 24, "EX": 24, "MX1": 41}
LOCK_ADDRESS = 47


class Protocol1Servo:
    """A Protocol 1.0 servo: the bus's servo interface (``id``, ``baudrate``, ``silent``, ``model``,
    ``read``/``write`` by name, ``state``) and the instructions' (``host_read``, ``host_write``,
    ``reg_write``, ``action``, ``factory_reset``, ``error_flags``)."""

    speaks_protocol_2 = False
    partner = None

    #: held while the shaft advances; a bus gives its servos its own lock (``VirtualBus.add_servo``)
    lock: threading.RLock = threading.RLock()

    def __init__(self, model: Model | int, servo_id: int, clock: Callable[[], float] = time.monotonic) -> None:
        self.model: Model = protocol1_model_by_number(model) if isinstance(model, int) else model
        self.baud_rates = dict(self.model.baud_rates)
        self.silent = False
        self.eeprom_changed = False
        self._clock = clock
        self._file = RegisterFile(self.model, FIRMWARE[self.model.family.name])
        self.registers = Registers(self.model, self._file, False)
        self.shaft = Shaft1(self.registers, clock())
        self.shaft.motor.p = float(self.model.position_zero_pulse)
        self._pending: bytes | None = None
        self._overloaded = False
        self._factory()
        self.registers.poke("id", servo_id)
        self.eeprom_changed = False

    # ------------------------------------------------------------------ values (tests, the bus)
    def _defaults(self) -> dict[str, int]:
        return {**self.model.factory, "model_number": self.model.number,
                "firmware_version": FIRMWARE[self.model.family.name]}

    def _factory(self) -> None:
        self._file.regs[:] = bytes(len(self._file.regs))
        for name, value in self._defaults().items():
            self.registers.poke(name, value)
        self.power_up()

    def power_up(self) -> None:
        """RAM back to its initial values, Torque Limit := Max Torque, Goal Position := Present."""
        now = self._clock()
        eeprom_end = self._file.eeprom_end
        self._file.regs[eeprom_end:] = bytes(len(self._file.regs) - eeprom_end)
        for name, value in self._defaults().items():
            if self.model.item(name).address >= eeprom_end:
                self.registers.poke(name, value)
        for eeprom, ram in self.model.ram_copies.items():
            self.registers.poke(ram, self.registers.peek(eeprom))
        self._pending, self._overloaded = None, False
        self.shaft.power_up(now)
        self.shaft.refresh(now)
        self.shaft.hold()

    def refresh(self) -> None:
        with self.lock:  # a test's read beside the serving thread must not advance the shaft twice
            self.shaft.refresh(self._clock())
            self._check_conditions()

    def read(self, name: str) -> int:
        """An item's value (signed where the item is), the shaft brought up to date first."""
        self.refresh()
        return self.registers.peek(name)

    def write(self, name: str, value: int) -> None:
        """Set an item with no checks (a test's way to set a state a host could not)."""
        self.refresh()
        self.registers.poke(name, int(value))

    def pin(self, name: str, value: int | None) -> None:
        """Hold a present value (a sensor reading, e.g. Present Temperature); None releases it."""
        self.model.item(name)
        if value is None:
            self.shaft.pinned.pop(name, None)
        else:
            self.shaft.pinned[name] = int(value)
        self.refresh()

    @property
    def mode(self) -> str:
        """Joint ("position"), Wheel ("velocity"), multi-turn ("ex_position") or torque ("current")."""
        return self.shaft.mode()

    @property
    def id(self) -> int:
        return self.registers.peek("id")

    @property
    def baudrate(self) -> int:
        """The line speed of its Baud Rate register: the e-Manual's nominal rate where it lists the
        value, else 2,000,000 / (value + 1)."""
        value = self.registers.peek("baud_rate")
        return self.baud_rates.get(value, round(actual_bps(value)))

    def hears(self, line_bps: int | None) -> bool:
        """Whether it decodes a host at ``line_bps`` (None: any speed): within 3 % of its actual rate."""
        actual = actual_bps(self.registers.peek("baud_rate"))
        return line_bps is None or abs(line_bps - actual) <= BAUD_TOLERANCE * line_bps

    @property
    def return_delay_s(self) -> float:
        return self.registers.peek("return_delay_time") * 2e-6

    @property
    def status_return_level(self) -> int:
        return self.registers.peek("status_return_level")

    @property
    def bulk_read(self) -> bool:
        """It answers a Bulk Read (MX and EX; AX, RX and DX do not know the instruction)."""
        return self.model.family.bulk_read

    # ------------------------------------------------------------------ errors
    def _check_conditions(self) -> None:
        """Overload (the load beyond Torque Limit) latches; a condition set in Shutdown cuts the
        output (Torque Limit 0)."""
        r = self.registers
        limit = r.peek("torque_limit")
        if limit > 0 and r.peek("torque_enable") and abs(self.shaft.load_share()) * 1023 > limit:
            self._overloaded = True
        if self._conditions() & r.peek("shutdown") and limit > 0:
            r.poke("torque_limit", 0)
            self.shaft.motor.stop()
            self.shaft.refresh(self._clock())

    def _conditions(self) -> int:
        r = self.registers
        bits = ERR_OVERLOAD if self._overloaded else 0
        volts = r.peek("present_input_voltage")
        if not r.peek("min_voltage_limit") <= volts <= r.peek("max_voltage_limit"):
            bits |= ERR_VOLTAGE
        if r.peek("present_temperature") > r.peek("temperature_limit"):
            bits |= ERR_OVERHEAT
        return bits

    def error_flags(self, error: int) -> int:
        """The status packet's error byte: ``error`` plus the conditions of the moment."""
        self.refresh()
        return error | self._conditions()

    # ------------------------------------------------------------------ host instructions
    def host_read(self, address: int, length: int) -> tuple[int, bytes]:
        self.refresh()
        data = self._file.read(address, length) if length >= 1 else None
        return (ERR_RANGE, b"") if data is None else (0, data)

    def check_write(self, address: int, data: bytes) -> tuple[int, bytearray]:
        """The error a write gets (0: none) and the table as it would be after it."""
        end = address + len(data)
        regs = self._file.regs
        if not data or address < 0 or end > len(regs):
            return ERR_RANGE, bytearray()
        new = bytearray(regs)
        new[address:end] = data
        if address < self._file.eeprom_end and regs[LOCK_ADDRESS]:
            return ERR_RANGE, bytearray()
        for it in self._file.items:
            error = self._item_error(it, new) if it.address < end and address < it.address + it.size else 0
            if error:
                return error, bytearray()
        return 0, new

    def _item_error(self, it: Item, new: bytearray) -> int:
        """The error a touched item's new bytes get (0: none)."""
        raw = new[it.address:it.address + it.size]
        if it.name in self.model.read_only:
            return ERR_RANGE
        if it.direction_bit and int.from_bytes(raw, "little") >> (it.direction_bit + 1):
            return ERR_RANGE  # a speed or torque beyond 0..2047
        return self._value_error(it.name, it.from_bytes(raw), new)

    def _value_error(self, name: str, value: int, new: bytearray) -> int:
        lo, hi = self.model.ranges.get(name, (-(1 << 31), 1 << 31))
        if not lo <= value <= hi or (name == "baud_rate" and value not in self.baud_rates):
            return ERR_RANGE
        if name == "goal_position":
            cw, ccw = (self.model.item(n).from_bytes(new[a:a + 2]) for n, a in
                       (("min_position_limit", 6), ("max_position_limit", 8)))
            if mode_of(cw, ccw) == "position" and not cw <= value <= ccw:
                return ERR_ANGLE
        return 0

    def host_write(self, address: int, data: bytes) -> int:
        self.refresh()
        error, new = self.check_write(address, data)
        if error:
            return error
        regs = self._file.regs
        if new[:self._file.eeprom_end] != regs[:self._file.eeprom_end]:
            self.eeprom_changed = True
        wheel_before = self.mode
        torque_limit_written = address <= 35 and address + len(data) > 34
        regs[:] = new
        if torque_limit_written and self.registers.peek("torque_limit") > 0:
            self._overloaded = False  # the Protocol 1.0 way out of a shutdown
        if self.mode == "position" and wheel_before != "position":
            self.shaft.fold()
        self.refresh()
        return 0

    def reg_write(self, address: int, data: bytes) -> int:
        """Reg Write: checked now, written at Action; Registered reads 1 meanwhile."""
        self.refresh()
        error, _ = self.check_write(address, data)
        if error:
            return error
        self._pending = bytes([address]) + bytes(data)
        self.registers.poke("registered_instruction", 1)
        return 0

    def action(self) -> int:
        """Action: the registered write; Instruction Error when none is registered."""
        if self._pending is None:
            return ERR_INSTRUCTION
        pending, self._pending = self._pending, None
        self.registers.poke("registered_instruction", 0)
        return self.host_write(pending[0], pending[1:])

    def factory_reset(self) -> None:
        """Reset (0x06): every item back to its factory value, ID 1 included."""
        self._factory()
        self.eeprom_changed = True

    # ------------------------------------------------------------------ state file
    def state(self) -> dict:
        """Its EEPROM, for the bus's ``--state`` file."""
        return {"protocol": 1, "model": self.model.number, "eeprom": self._file.eeprom_image().hex()}

    @classmethod
    def from_state(cls, entry: dict, clock: Callable[[], float] = time.monotonic) -> "Protocol1Servo":
        servo = cls(int(entry["model"]), 1, clock)
        eeprom = bytes.fromhex(entry["eeprom"])[:servo._file.eeprom_end]
        servo._file.regs[:len(eeprom)] = eeprom
        servo.registers.poke("model_number", servo.model.number)
        servo.power_up()
        return servo


def turn_by_hand1(servo: Protocol1Servo, deg: float) -> None:
    """Turn ``servo``'s shaft by hand until Present Position reads ``deg`` (the handler's degrees: 0
    at the model's middle position; in Joint Mode within the sensor's range)."""
    with servo.lock:
        servo.refresh()
        servo.shaft.turn_to(servo.model.position_zero_pulse + deg / servo.model.position_deg_per_pulse)
        servo.refresh()
