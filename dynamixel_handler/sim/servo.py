"""One virtual servo, of any family and protocol: a register file with the write rules of its
firmware, plus motion.

Why a register file and not a dict of values: hosts read and write arbitrary address ranges
(sync read of 116..147, bulk write across items), so the servo keeps the bytes exactly where
the control table puts them and checks every write the way its firmware does (``firmware``: item by
item on Protocol 2.0, where read-only items and EEPROM-while-torque-on give an access error,
malformed spans a length error, bad enum values a range error, goals beyond their limits a limit
error; byte by byte on Protocol 1.0, ``byte_rules``), and nothing is written on error. Errors are
the engine's codes (``protocol.servo``); each protocol's instruction set frames them.
"""

from __future__ import annotations

import threading
from typing import Callable

from dynamixel_handler.control_table import Item, Model, model_by_number

from ..protocol import servo as p
from . import error_codes
from .defaults import factory_defaults, family
from .dynamics import Dynamics
from .firmware import firmware_of
from .memory import Memory
from .motion import Motor
from .registers import RegisterFile, Registers

CLEAR_KEY = bytes([0x01, 0x44, 0x58, 0x4C, 0x22])


class VirtualServo:
    """A servo on the virtual bus. Values are in pulses (raw register units).

    It answers the host's instructions over its parts: ``Registers`` (the control table's bytes by
    item name), ``Dynamics`` (the shaft and the present values it writes), ``Memory`` (power cycles,
    factory reset, backup, the EEPROM a state file keeps), ``errors`` (``error_state``); its
    ``firmware`` says which written values it refuses and what else differs per protocol family."""

    #: held while the shaft advances; a bus gives its servos its own lock (``VirtualBus.add_servo``)
    lock: threading.RLock = threading.RLock()

    def __init__(self, model: Model | int, servo_id: int, clock: Callable[[], float]) -> None:
        self.model: Model = model_by_number(model) if isinstance(model, int) else model
        self.family = family(self.model)
        self.firmware = firmware_of(self.model)
        self._clock = clock
        defaults = factory_defaults(self.model, servo_id)
        self._file = RegisterFile(self.model, defaults["firmware_version"])
        self.registers = Registers(self.model, self._file, self.model.family.x_table)
        self.baud_rates = self.registers.baud_rates
        self._memory = Memory(self.registers, defaults)
        now = clock()
        self._dynamics = Dynamics(self.registers, now, self.firmware)
        self._dynamics.supply_v = self.family.nominal_v
        self.errors = self.firmware.errors(self.registers, self._dynamics)
        #: set when an EEPROM byte changes (the bus saves its state file then)
        self.eeprom_changed = False
        #: the other axis of a dual servo (2XL430, 2XC430): the two share one Baud Rate
        self.partner: VirtualServo | None = None
        self.silent = False
        self._pending: tuple[int, bytes] | None = None  # a registered write, run by Action
        for name, value in defaults.items():
            self.registers.poke(name, value)
        self._file.factory_indirect()
        self._dynamics.motor.p = self._dynamics.fold(float(self.model.position_zero_pulse))
        self._memory.power_cycle()
        self._powered_up(now)

    # ------------------------------------------------------------------ public (tests, API)
    @property
    def id(self) -> int:
        return self.registers.peek("id")

    @property
    def _motor(self) -> Motor:
        return self._dynamics.motor  # the shaft (tests turn it by hand)

    @property
    def shaft(self) -> Dynamics:
        """The motion model (tests set ``supply_v``, ``ambient_c`` and ``external_load`` on it)."""
        return self._dynamics

    @property
    def mode(self) -> str | None:
        """The mode its registers select, by name (Protocol 1.0: Joint is "position", Wheel "velocity")."""
        return self._dynamics.mode()

    def refresh(self, now: float | None = None) -> float:
        """Advance motion to ``now`` (default: the clock's), rewrite the present values; gives ``now``."""
        now = self._clock() if now is None else now
        with self.lock:  # a test's read beside the serving thread must not advance the shaft twice
            self._dynamics.refresh(now)
            self.errors.check(now)
        return now

    def read(self, name: str) -> int:
        """Current value of an item (signed per item), physics brought up to date first."""
        self.refresh()
        return self.registers.peek(name)

    def write(self, name: str, value: int) -> None:
        """Poke a value with no checks (a test's way to set a state a host could not)."""
        self.refresh()
        self.registers.poke(name, int(value))
        self.errors.set(name, int(value))  # Hardware Error Status, or a Y Error Code

    def pin(self, name: str, value: int | None) -> None:
        """Hold a present-value item at ``value`` (None releases it), e.g. a sensor reading."""
        self.model.item(name)
        if value is None:
            self._dynamics.pinned.pop(name, None)
        else:
            self._dynamics.pinned[name] = int(value)
        self.refresh()

    def read_raw(self, address: int, size: int) -> bytes:
        self.refresh()
        return bytes(self._file.regs[address:address + size])

    def set_hardware_error(self, bits: int) -> None:
        """Raise hardware error bits; torque drops if any is in the shutdown mask."""
        self.write("hardware_error_status", bits & 0xFF)

    @property
    def supports_fast_read(self) -> bool:
        return self.family.fast_read and self.registers.peek("firmware_version") >= self.family.fast_read_from

    @property
    def return_delay_s(self) -> float:
        return self.registers.peek("return_delay_time") * 2e-6

    @property
    def protocol(self) -> int:
        """The protocol it answers: its Protocol Type register where it has one, else its family's."""
        return self.registers.get("protocol_type", self.model.family.protocol)

    @property
    def baudrate(self) -> int | None:
        """The line speed (bps) of its Baud Rate register (None: a value the model does not know)."""
        return self.firmware.baudrate(self.model, self.registers.peek("baud_rate"))

    def hears(self, line_bps: int | None) -> bool:
        """Whether it decodes a host at ``line_bps`` (None: any speed)."""
        return self.firmware.hears(self.model, self.registers.peek("baud_rate"), line_bps)

    @property
    def status_return_level(self) -> int:
        return self.registers.peek("status_return_level")

    def error_flags(self, error: int) -> int:
        """A Protocol 2.0 status packet's error byte: ``error`` plus the alert bit on a hardware error."""
        return error | (p.ALERT_BIT if self.errors.alert() else 0)

    # ------------------------------------------------------------------ host instructions
    def note_instruction(self, now: float) -> None:
        """An instruction for this servo arrived: feeds the bus watchdog."""
        self.refresh(now)
        self._dynamics.last_instruction = now

    def host_read(self, address: int, length: int, now: float | None = None) -> tuple[int, bytes]:
        self.refresh(now)
        data = self._file.read(address, length) if length >= self.firmware.min_read else None
        return (p.ERR_ACCESS, b"") if data is None else (p.ERR_NONE, data)

    def check_write(self, address: int, data: bytes) -> tuple[int, list[tuple[Item, int]]]:
        """Validate a write without applying it: (error, [(item, value)]) (the firmware's rules)."""
        return self.firmware.check_write(self.registers, address, data, self.errors.latched)

    def host_write(self, address: int, data: bytes, now: float | None = None) -> int:
        now = self.refresh(now)
        error, changes = self.check_write(address, data)
        if error:
            return error
        mode = self._dynamics.mode()
        for it, value in changes:
            self._apply(it, value, now)
        self._dynamics.mode_written(mode)
        return p.ERR_NONE

    def reg_write(self, address: int, data: bytes, now: float | None = None) -> int:
        self.refresh(now)
        error, _ = self.check_write(address, data)
        if error:
            return error
        self._pending = (address, bytes(data))
        self.registers.poke("registered_instruction", 1)
        return p.ERR_NONE

    def action(self, now: float | None = None) -> int:
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
        self.errors.latched &= error != p.ERR_NONE
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
    def reboot(self, now: float | None = None) -> None:
        """Power cycle: RAM back to defaults, multi-turn folded, errors cleared; EEPROM, the Indirect
        Address entries and a control-table backup kept (Protocol 1.0: Goal Position := Present)."""
        now = self.refresh(now)
        self._memory.power_cycle()
        self._powered_up(now)

    def _powered_up(self, now: float) -> None:
        self._dynamics.restart(now)
        self._pending = None
        self.errors.power_cycle()
        if self.registers.get("startup_configuration") & 0x01:
            self.registers.poke("torque_enable", 1)
            self._dynamics.torque_changed(0, 1, now)
        if self.firmware.hold_at_power_on:
            self.refresh(now)
            self._dynamics.hold()

    def factory_reset(self, option: int = 0xFF, now: float | None = None) -> None:
        self._memory.factory_values(option)
        if self.partner is not None:
            self.partner.registers.poke("baud_rate", self.registers.peek("baud_rate"))
        self.eeprom_changed = True
        self.reboot(now)

    def backup(self, params: bytes, now: float) -> int:
        """Control Table Backup (0x20): see ``Memory.backup``."""
        self.refresh(now)
        error = self._memory.backup(params)
        self.eeprom_changed |= error == p.ERR_NONE
        return error

    def state(self) -> dict:
        """What survives a power cycle, as JSON-ready values (the bus's ``--state`` file)."""
        return self._memory.state()

    def load_state(self, state: dict, now: float) -> None:
        """Power up with a saved EEPROM (and backup), RAM at its defaults."""
        self._memory.load(state)
        self.reboot(now)

    # ------------------------------------------------------------------ what a write does
    def _apply(self, it: Item, value: int, now: float) -> None:
        """Store an accepted value and do what the firmware does when that item changes."""
        registers, dynamics, name = self.registers, self._dynamics, it.name
        old = self._file.peek(it)
        self._file.poke(it, value)
        self.eeprom_changed |= it.eeprom and old != value
        self.errors.host_wrote(name, value)
        if name == "torque_enable":
            dynamics.torque_changed(old, value, now)
        elif name == "operating_mode" and value != old:
            self._memory.mode_changed()
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


def turn_by_hand(servo: VirtualServo, deg: float) -> None:
    """Turn ``servo``'s shaft by hand until Present Position reads ``deg`` (the handler's degrees:
    0 at the model's middle position), as someone moving a joint with the torque off would (on a
    Protocol 1.0 servo in Joint Mode within its sensor's range)."""
    with servo.lock:
        servo.refresh()
        servo._dynamics.turn_to(servo.model.position_zero_pulse + deg / servo.model.position_deg_per_pulse)
        servo.refresh()
