"""One virtual servo: a register file with the write rules of the real firmware, plus motion.

Why a register file and not a dict of values: hosts read and write arbitrary address ranges
(sync read of 116..147, bulk write across items), so the servo keeps the bytes exactly where
the control table puts them and checks every write the way a servo does: read-only items and
EEPROM-while-torque-on give an access error, malformed spans a length error, bad enum values a
range error, goals beyond their limits a limit error, and nothing is written on error.
"""

from __future__ import annotations

from typing import Callable

from dynamixel_handler.control_table import Item, Model, model_by_number

from ..protocol import servo as p
from .defaults import MODE_RESET_ITEMS, READ_ONLY, factory_defaults, family
from .memory import ServoMemory
from .motion import Motor, profile_kind
from .registers import RegisterFile
from .write_rules import Changes, check_value

CLEAR_KEY = bytes([0x01, 0x44, 0x58, 0x4C, 0x22])


class VirtualServo(ServoMemory):
    """A servo on the virtual bus. Values are in pulses (raw register units).

    This class answers the host's instructions; ``ServoMemory`` powers it up, resets it and
    keeps its EEPROM, ``ServoDynamics`` moves the shaft and writes the present values, and
    ``write_rules`` decides which written values a servo refuses."""

    def __init__(self, model: Model | int, servo_id: int, clock: Callable[[], float]) -> None:
        self.model: Model = model_by_number(model) if isinstance(model, int) else model
        self.layout = self.model.layout
        self._x = self.model.family.x_table
        self.family = family(self.model)
        self.baud_rates = dict(self.model.baud_rates)
        self._clock = clock
        self._defaults = factory_defaults(self.model, servo_id)
        self._file = RegisterFile(self.model, self._defaults["firmware_version"])
        self._regs = self._file.regs
        self._items = self._file.items
        self._eeprom_end = self._file.eeprom_end
        self._backup: bytes | None = None
        #: set when an EEPROM byte changes (the bus saves its state file then)
        self.eeprom_changed = False
        #: the other axis of a dual servo (2XL430, 2XC430): the two share one Baud Rate
        self.partner: VirtualServo | None = None
        self.silent = False
        self._motor = Motor()
        self._port_latch: dict[int, int] = {}
        self._pending: tuple[int, bytes] | None = None
        self._shutdown_latched = False
        self._profile_kind = 0
        self._pinned: dict[str, int] = {}
        self.supply_v = self.family.nominal_v
        self.ambient_c = 30
        now = clock()
        self._t = now
        self._boot = now
        self._last_instruction = now
        for name, value in self._defaults.items():
            self._poke(name, value)
        self._file.factory_indirect()
        self._motor.p = self._fold(float(self.model.position_zero_pulse))

    # ------------------------------------------------------------------ public (tests, API)
    @property
    def id(self) -> int:
        return self._peek("id")

    def read(self, name: str) -> int:
        """Current value of an item (signed per item), physics brought up to date first."""
        self.refresh(self._clock())
        return self._peek(name)

    def write(self, name: str, value: int) -> None:
        """Poke a value with no checks (a test's way to set a state a host could not)."""
        self.refresh(self._clock())
        self._poke(name, int(value))
        if name == "hardware_error_status":
            self._apply_hardware_error(int(value))

    def pin(self, name: str, value: int | None) -> None:
        """Hold a present-value item at ``value`` (None releases it), e.g. a sensor reading."""
        self.model.item(name)
        if value is None:
            self._pinned.pop(name, None)
        else:
            self._pinned[name] = int(value)
        self.refresh(self._clock())

    def read_raw(self, address: int, size: int) -> bytes:
        self.refresh(self._clock())
        return bytes(self._regs[address:address + size])

    def set_hardware_error(self, bits: int) -> None:
        """Raise hardware error bits; torque drops if any is in the shutdown mask."""
        self.refresh(self._clock())
        self._poke("hardware_error_status", bits & 0xFF)
        self._apply_hardware_error(bits & 0xFF)

    @property
    def supports_fast_read(self) -> bool:
        fw = self._peek("firmware_version")
        if not self.family.fast_read:
            return False
        if self._x:
            return fw >= (46 if self.layout == "X330" else 45)
        return fw >= 12

    @property
    def return_delay_s(self) -> float:
        return self._peek("return_delay_time") * 2e-6

    @property
    def baudrate(self) -> int | None:
        """The line speed (bps) the servo listens at: its Baud Rate register, decoded."""
        return self.baud_rates.get(self._peek("baud_rate"))

    @property
    def speaks_protocol_2(self) -> bool:
        """False when Protocol Type is set to 1 (Protocol 1.0, which this bus does not speak)."""
        return self._get("protocol_type", 2) == 2

    @property
    def status_return_level(self) -> int:
        return self._peek("status_return_level")

    def error_flags(self, error: int) -> int:
        """The status packet's error byte: ``error`` plus the alert bit on a hardware error."""
        return error | (p.ALERT_BIT if self._peek("hardware_error_status") else 0)

    # ------------------------------------------------------------------ host instructions
    def note_instruction(self, now: float) -> None:
        """An instruction for this servo arrived: feeds the bus watchdog."""
        self.refresh(now)
        self._last_instruction = now

    def host_read(self, address: int, length: int, now: float) -> tuple[int, bytes]:
        self.refresh(now)
        data = self._file.read(address, length)
        return (p.ERR_ACCESS, b"") if data is None else (p.ERR_NONE, data)

    def check_write(self, address: int, data: bytes) -> tuple[int, list[tuple[Item, int]]]:
        """Validate a write without applying it; returns (error, [(item, value)]).

        Indirect Data bytes count as the items they map; plain Indirect Data storage is
        returned as pseudo items of one byte."""
        error, changes, raw = self._file.gather(address, data)
        if error:
            return error, []
        torque_on = self._peek("torque_enable") == 1
        lo, hi = self.model.indirect_targets
        for it, value in changes:
            if it.name in READ_ONLY:
                return p.ERR_ACCESS, []
            if it.eeprom and torque_on:
                return p.ERR_ACCESS, []
            if it.name.startswith("indirect_address_"):
                if not lo <= value <= hi:
                    return p.ERR_DATA_RANGE, []
                continue
            error = self._check_value(it.name, value, changes)
            if error:
                return error, []
        return p.ERR_NONE, changes + [(Item(f"indirect_data_{a}", a, 1, False, False), b) for a, b in raw]

    def host_write(self, address: int, data: bytes, now: float) -> int:
        self.refresh(now)
        error, changes = self.check_write(address, data)
        if error:
            return error
        for it, value in changes:
            if it.name.startswith("indirect_"):
                self._file.poke(it, value)
                self.eeprom_changed |= it.eeprom
            else:
                self._apply(it.name, value, now)
                self.eeprom_changed |= it.eeprom
        return p.ERR_NONE

    def reg_write(self, address: int, data: bytes, now: float) -> int:
        self.refresh(now)
        error, _ = self.check_write(address, data)
        if error:
            return error
        self._pending = (address, bytes(data))
        self._poke("registered_instruction", 1)
        return p.ERR_NONE

    def action(self, now: float) -> int:
        if self._pending is None:
            return p.ERR_INSTRUCTION
        address, data = self._pending
        self._pending = None
        self._poke("registered_instruction", 0)
        return self.host_write(address, data, now)

    def clear_multi_turn(self, params: bytes, now: float) -> int:
        self.refresh(now)
        if params != CLEAR_KEY:
            return p.ERR_DATA_RANGE
        if abs(self._motor.v) > self._threshold_pulses():
            return p.ERR_RESULT_FAIL
        self._motor.p = self._fold(self._motor.p)
        self._hold_if_position_mode()
        return p.ERR_NONE

    # ------------------------------------------------------------------ write rules
    def _check_value(self, name: str, value: int, changes: Changes) -> int:
        return check_value(self, name, value, changes)

    def _apply(self, name: str, value: int, now: float) -> None:
        """Store an accepted value and do what the firmware does when that item changes."""
        old = self._get(name)
        self._poke(name, value)
        if name == "torque_enable":
            self._torque_changed(old, value, now)
        elif name == "operating_mode" and value != old:
            self._mode_changed(value)
        elif name == "baud_rate" and self.partner is not None:
            self.partner._poke("baud_rate", value)
            self.partner.eeprom_changed = True
        elif name == "bus_watchdog":
            self._last_instruction = now
        elif name == "goal_position":
            cmd = self._command()
            if cmd.target_p is not None:
                self._profile_kind = profile_kind(cmd.target_p - self._motor.p, cmd.vmax, cmd.amax)
        elif name.startswith("external_port_data_"):
            self._port_latch[int(name[-1])] = value

    def _mode_changed(self, value: int) -> None:
        """The e-Manual: a new operating mode puts gains and profiles back to their defaults."""
        for reset in MODE_RESET_ITEMS:
            if reset in self._defaults:
                self._poke(reset, self._defaults[reset])
        if value == 3:
            self._motor.p = self._fold(self._motor.p)

    def _apply_hardware_error(self, bits: int) -> None:
        if bits & self._get("shutdown", 0xFF):
            self._shutdown_latched = True
            self._poke("torque_enable", 0)
            self._motor.stop()
        elif bits == 0:
            self._shutdown_latched = False
