"""One virtual servo: a register file with the write rules of the real firmware, plus motion.

Why a register file and not a dict of values: hosts read and write arbitrary address ranges
(sync read of 116..147, bulk write across items), so the servo keeps the bytes exactly where
the control table puts them and checks every write the way a servo does: read-only items and
EEPROM-while-torque-on give an access error, malformed spans a length error, bad enum values a
range error, goals beyond their limits a limit error, and nothing is written on error.
"""

from __future__ import annotations

import threading
from typing import Callable

from dynamixel_handler.control_table import Item, Model, model_by_number

from ..protocol import servo as p
from . import error_codes
from .defaults import MODE_RESET_ITEMS, factory_defaults, family
from .dynamics import Dynamics
from .memory import Memory
from .motion import Motor
from .registers import RegisterFile, Registers
from .write_rules import check_write

CLEAR_KEY = bytes([0x01, 0x44, 0x58, 0x4C, 0x22])


class VirtualServo:
    """A servo on the virtual bus. Values are in pulses (raw register units).

    This class answers the host's instructions over its parts: ``Registers`` (the control table's
    bytes by item name), ``Dynamics`` (the shaft behind the registers and the present values it
    writes), ``Memory`` (power cycles, factory reset, backup, the EEPROM a state file keeps);
    ``write_rules`` decides which written values a servo refuses."""

    #: held while the shaft advances; a bus gives its servos its own lock (``VirtualBus.add_servo``)
    lock: threading.RLock = threading.RLock()

    def __init__(self, model: Model | int, servo_id: int, clock: Callable[[], float]) -> None:
        self.model: Model = model_by_number(model) if isinstance(model, int) else model
        self.layout = self.model.layout
        self.family = family(self.model)
        self._clock = clock
        defaults = factory_defaults(self.model, servo_id)
        self._file = RegisterFile(self.model, defaults["firmware_version"])
        self.registers = Registers(self.model, self._file, self.model.family.x_table)
        self.baud_rates = self.registers.baud_rates
        self._memory = Memory(self.registers, defaults)
        now = clock()
        self._dynamics = Dynamics(self.registers, now)
        self._dynamics.supply_v = self.family.nominal_v
        #: set when an EEPROM byte changes (the bus saves its state file then)
        self.eeprom_changed = False
        #: the other axis of a dual servo (2XL430, 2XC430): the two share one Baud Rate
        self.partner: VirtualServo | None = None
        self.silent = False
        self._pending: tuple[int, bytes] | None = None  # a registered write, run by Action
        self._shutdown_latched = False
        for name, value in defaults.items():
            self.registers.poke(name, value)
        self._file.factory_indirect()
        self._dynamics.motor.p = self._dynamics.fold(float(self.model.position_zero_pulse))

    # ------------------------------------------------------------------ public (tests, API)
    @property
    def id(self) -> int:
        return self.registers.peek("id")

    @property
    def _motor(self) -> Motor:
        """The shaft (tests turn it by hand)."""
        return self._dynamics.motor

    def refresh(self, now: float) -> None:
        """Advance motion to ``now`` and rewrite every present-value register."""
        with self.lock:  # a test's read beside the serving thread must not advance the shaft twice
            self._dynamics.refresh(now)

    def read(self, name: str) -> int:
        """Current value of an item (signed per item), physics brought up to date first."""
        self.refresh(self._clock())
        return self.registers.peek(name)

    def write(self, name: str, value: int) -> None:
        """Poke a value with no checks (a test's way to set a state a host could not)."""
        self.refresh(self._clock())
        self.registers.poke(name, int(value))
        if name in error_codes.ERROR_ITEMS:  # Hardware Error Status, or a Y Error Code
            self._apply_hardware_error(int(value), name)

    def pin(self, name: str, value: int | None) -> None:
        """Hold a present-value item at ``value`` (None releases it), e.g. a sensor reading."""
        self.model.item(name)
        if value is None:
            self._dynamics.pinned.pop(name, None)
        else:
            self._dynamics.pinned[name] = int(value)
        self.refresh(self._clock())

    def read_raw(self, address: int, size: int) -> bytes:
        self.refresh(self._clock())
        return bytes(self._file.regs[address:address + size])

    def set_hardware_error(self, bits: int) -> None:
        """Raise hardware error bits; torque drops if any is in the shutdown mask."""
        self.refresh(self._clock())
        self.registers.poke("hardware_error_status", bits & 0xFF)
        self._apply_hardware_error(bits & 0xFF)

    @property
    def supports_fast_read(self) -> bool:
        least = (46 if self.layout == "X330" else 45) if self.registers.x else 12  # firmware with it
        return self.family.fast_read and self.registers.peek("firmware_version") >= least

    @property
    def return_delay_s(self) -> float:
        return self.registers.peek("return_delay_time") * 2e-6

    @property
    def baudrate(self) -> int | None:
        """The line speed (bps) the servo listens at: its Baud Rate register, decoded."""
        return self.baud_rates.get(self.registers.peek("baud_rate"))

    @property
    def speaks_protocol_2(self) -> bool:
        """False when Protocol Type is set to 1 (Protocol 1.0, which this bus does not speak)."""
        return self.registers.get("protocol_type", 2) == 2

    @property
    def status_return_level(self) -> int:
        return self.registers.peek("status_return_level")

    def error_flags(self, error: int) -> int:
        """The status packet's error byte: ``error`` plus the alert bit on a hardware error."""
        return error | (p.ALERT_BIT if error_codes.alert(self.registers) else 0)

    # ------------------------------------------------------------------ host instructions
    def note_instruction(self, now: float) -> None:
        """An instruction for this servo arrived: feeds the bus watchdog."""
        self.refresh(now)
        self._dynamics.last_instruction = now

    def host_read(self, address: int, length: int, now: float) -> tuple[int, bytes]:
        self.refresh(now)
        data = self._file.read(address, length)
        return (p.ERR_ACCESS, b"") if data is None else (p.ERR_NONE, data)

    def check_write(self, address: int, data: bytes) -> tuple[int, list[tuple[Item, int]]]:
        """Validate a write without applying it; returns (error, [(item, value)]) (see
        ``write_rules.check_write``)."""
        return check_write(self.registers, address, data, self._shutdown_latched)

    def host_write(self, address: int, data: bytes, now: float) -> int:
        self.refresh(now)
        error, changes = self.check_write(address, data)
        if error:
            return error
        for it, value in changes:
            if it.name.startswith("indirect_"):
                self._file.poke(it, value)
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
        self.registers.poke("registered_instruction", 1)
        return p.ERR_NONE

    def action(self, now: float) -> int:
        if self._pending is None:
            return p.ERR_INSTRUCTION
        address, data = self._pending
        self._pending = None
        self.registers.poke("registered_instruction", 0)
        return self.host_write(address, data, now)

    def clear(self, params: bytes, now: float) -> int:
        """Clear (0x10): the multi-turn clear, or (Y) the error clear (``error_codes.clear``)."""
        if not error_codes.is_error_clear(self.model, params):
            return self.clear_multi_turn(params, now)
        self.refresh(now)
        error = error_codes.clear(self.registers)
        self._shutdown_latched &= error != p.ERR_NONE
        return error

    def clear_multi_turn(self, params: bytes, now: float) -> int:
        self.refresh(now)
        if params != CLEAR_KEY:
            return p.ERR_DATA_RANGE
        dynamics = self._dynamics
        if abs(dynamics.motor.v) > dynamics.threshold_pulses():
            return p.ERR_RESULT_FAIL
        dynamics.motor.p = dynamics.fold(dynamics.motor.p)
        dynamics.hold_if_position_mode()
        return p.ERR_NONE

    # ------------------------------------------------------------------ power cycles
    def reboot(self, now: float) -> None:
        """Power cycle: RAM back to defaults, multi-turn folded to one turn, errors cleared.
        EEPROM, the Indirect Address entries and a control-table backup are kept."""
        self.refresh(now)
        self._memory.power_cycle()
        self._dynamics.restart(now)
        self._pending = None
        self._shutdown_latched = False
        if self.registers.get("startup_configuration") & 0x01:
            self.registers.poke("torque_enable", 1)
            self._dynamics.torque_changed(0, 1, now)

    def factory_reset(self, option: int, now: float) -> None:
        self._memory.factory_values(option)
        if self.partner is not None:
            self.partner.registers.poke("baud_rate", self.registers.peek("baud_rate"))
        self.eeprom_changed = True
        self.reboot(now)

    def backup(self, params: bytes, now: float) -> int:
        """Control Table Backup (0x20): see ``Memory.backup``."""
        self.refresh(now)
        error = self._memory.backup(params)
        if error == p.ERR_NONE:
            self.eeprom_changed = True
        return error

    def state(self) -> dict:
        """What survives a power cycle, as JSON-ready values (the bus's ``--state`` file)."""
        return self._memory.state()

    def load_state(self, state: dict, now: float) -> None:
        """Power up with a saved EEPROM (and backup), RAM at its defaults."""
        self._memory.load(state)
        self.reboot(now)

    # ------------------------------------------------------------------ what a write does
    def _apply(self, name: str, value: int, now: float) -> None:
        """Store an accepted value and do what the firmware does when that item changes."""
        registers, dynamics = self.registers, self._dynamics
        old = registers.get(name)
        registers.poke(name, value)
        if name == "torque_enable":
            dynamics.torque_changed(old, value, now)
        elif name == "operating_mode" and value != old:
            self._mode_changed(value)
        elif name == "baud_rate" and self.partner is not None:
            self.partner.registers.poke("baud_rate", value)
            self.partner.eeprom_changed = True
        elif name == "bus_watchdog":
            dynamics.last_instruction = now
            error_codes.watchdog_written(registers, value)
        elif name == "goal_position":
            dynamics.goal_position_changed()
        elif name.startswith("external_port_data_"):
            dynamics.port_latch[int(name[-1])] = value

    def _mode_changed(self, value: int) -> None:
        """The e-Manual: a new operating mode puts gains and profiles back to their defaults (not
        those Y keeps in its Hybrid area)."""
        defaults = self._memory.defaults
        for reset in MODE_RESET_ITEMS:
            if reset in defaults and reset not in self.model.hybrid_items:
                self.registers.poke(reset, defaults[reset])
        if self.model.mode_name(value) == "position":
            self._dynamics.motor.p = self._dynamics.fold(self._dynamics.motor.p)

    def _apply_hardware_error(self, bits: int, item: str = "hardware_error_status") -> None:
        if error_codes.switches_torque_off(self.registers, item, bits):
            self._shutdown_latched = True
            self.registers.poke("torque_enable", 0)
            self._dynamics.motor.stop()
        elif bits == 0:
            self._shutdown_latched = False


def turn_by_hand(servo: VirtualServo, deg: float) -> None:
    """Turn ``servo``'s shaft by hand until Present Position reads ``deg`` (the handler's degrees:
    0 at the model's middle position), as someone moving a joint with the torque off would."""
    with servo.lock:
        servo.refresh(servo._clock())
        servo._dynamics.turn_to(servo.model.position_zero_pulse + deg / servo.model.position_deg_per_pulse)
        servo.refresh(servo._clock())
