"""One virtual servo: a register file with the write rules of the real firmware, plus motion.

Why a register file and not a dict of values: hosts read and write arbitrary address ranges
(sync read of 116..147, bulk write across items), so the servo keeps the bytes exactly where
the control table puts them and checks every write the way a servo does: read-only items and
EEPROM-while-torque-on give an access error, malformed spans a length error, bad enum values a
range error, goals beyond their limits a limit error, and nothing is written on error.
"""

from __future__ import annotations

import math
from typing import Callable

from dynamixel_handler.control_table import Item, Model, model_by_number

from ..protocol import servo as p
from .defaults import MODE_RESET_ITEMS, READ_ONLY, factory_defaults, family
from .motion import Command, Motor, profile_kind
from .registers import RegisterFile

POSITION_MODES = (3, 4, 5)
EXTENDED_MODES = (4, 5)
X_EXTENDED_GOAL_LIMIT = 1_048_575
X_HOMING_MAX = 1_044_479
X_GAIN_MAX = 16383
X_GAINS = ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain", "position_p_gain",
           "feedforward_2nd_gain", "feedforward_1st_gain")
CLEAR_KEY = bytes([0x01, 0x44, 0x58, 0x4C, 0x22])
BACKUP_KEY = b"CTRL"  # Control Table Backup: 0x01 (store) or 0x02 (restore), then "CTRL"
LAG_S = 0.05
_ANALOG_INPUT = 2048


class VirtualServo:
    """A servo on the virtual bus. Values are in pulses (raw register units)."""

    def __init__(self, model: Model | int, servo_id: int, clock: Callable[[], float]) -> None:
        self.model: Model = model_by_number(model) if isinstance(model, int) else model
        self.layout = self.model.layout
        self._x = self.model.series == "X"
        self.family = family(self.model)
        self.baud_rates = dict(self.model.baud_rates)
        self._clock = clock
        self._defaults = factory_defaults(self.model, servo_id)
        self._file = RegisterFile(self.model, self._defaults["firmware_version"])
        self._regs = self._file.regs
        self._items = self._file.items
        self._eeprom_end = min((it.address for it in self._items if not it.eeprom), default=len(self._regs))
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

    # ------------------------------------------------------------------ registers
    def _peek(self, name: str) -> int:
        it = self.model.item(name)
        return int.from_bytes(self._regs[it.address:it.address + it.size], "little", signed=it.signed)

    def _poke(self, name: str, value: int) -> None:
        if not self.model.has(name):
            return
        it = self.model.item(name)
        mask = (1 << (8 * it.size)) - 1
        self._regs[it.address:it.address + it.size] = (int(value) & mask).to_bytes(it.size, "little")

    def _has(self, name: str) -> bool:
        return self.model.has(name)

    def _get(self, name: str, default: int = 0) -> int:
        return self._peek(name) if self.model.has(name) else default

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

    def reboot(self, now: float) -> None:
        """Power cycle: RAM back to defaults, multi-turn folded to one turn, errors cleared.
        EEPROM, the Indirect Address entries and a control-table backup are kept."""
        self.refresh(now)
        ram_start = self._eeprom_end
        kept = [(it, self._file.peek(it)) for it in self._file.indirect_addresses]
        self._regs[ram_start:] = bytes(len(self._regs) - ram_start)
        for it, value in kept:
            self._file.poke(it, value)
        for name, value in self._defaults.items():
            if self.model.item(name).address >= ram_start:
                self._poke(name, value)
        self._poke("backup_ready", 1 if self._backup is not None else 0)
        self._motor.stop()
        self._motor.p = self._fold(self._motor.p)
        self._pending = None
        self._shutdown_latched = False
        self._port_latch.clear()
        self._boot = now
        self._last_instruction = now
        if self._get("startup_configuration") & 0x01:
            self._apply("torque_enable", 1, now)

    def factory_reset(self, option: int, now: float) -> None:
        keep = {}
        if option in (0x01, 0x02):
            keep["id"] = self._peek("id")
        if option == 0x02:
            keep["baud_rate"] = self._peek("baud_rate")
        for name, value in self._defaults.items():
            self._poke(name, keep.get(name, 1 if name == "id" else value))
        if self.partner is not None:
            self.partner._poke("baud_rate", self._peek("baud_rate"))
        self._file.factory_indirect()
        self.eeprom_changed = True
        self.reboot(now)

    # ------------------------------------------------------------------ backup, state
    def _eeprom_image(self) -> bytes:
        """The bytes a backup (and a state file) keeps: the EEPROM area and the Indirect
        Address entries."""
        out = bytearray(self._regs[:self._eeprom_end])
        for it in self._file.indirect_addresses:
            if it.address >= self._eeprom_end:
                out += self._regs[it.address:it.address + it.size]
        return bytes(out)

    def _load_eeprom_image(self, image: bytes) -> None:
        self._regs[:self._eeprom_end] = image[:self._eeprom_end]
        k = self._eeprom_end
        for it in self._file.indirect_addresses:
            if it.address >= self._eeprom_end:
                self._regs[it.address:it.address + it.size] = image[k:k + it.size]
                k += it.size

    def backup(self, params: bytes, now: float) -> int:
        """Control Table Backup (0x20): 0x01 "CTRL" stores the EEPROM area, 0x02 "CTRL" puts it
        back. Models without Backup Ready do not know the instruction; torque must be off."""
        self.refresh(now)
        if not self.model.has("backup_ready"):
            return p.ERR_INSTRUCTION
        if len(params) != 5 or params[1:] != BACKUP_KEY or params[0] not in (0x01, 0x02):
            return p.ERR_DATA_RANGE
        if self._peek("torque_enable") == 1:
            return p.ERR_ACCESS
        if params[0] == 0x01:
            self._backup = self._eeprom_image()
            self._poke("backup_ready", 1)
        elif self._backup is None:
            return p.ERR_RESULT_FAIL
        else:
            keep = {n: self._peek(n) for n in ("id", "model_number", "firmware_version")}
            self._load_eeprom_image(self._backup)
            for name, value in keep.items():  # the servo stays where the host reached it
                self._poke(name, value)
        self.eeprom_changed = True
        return p.ERR_NONE

    def state(self) -> dict:
        """What survives a power cycle, as JSON-ready values (the bus's ``--state`` file)."""
        return {"model": self.model.number, "eeprom": self._eeprom_image().hex(),
                "backup": self._backup.hex() if self._backup is not None else None}

    def load_state(self, state: dict, now: float) -> None:
        """Power up with a saved EEPROM (and backup), RAM at its defaults."""
        self._load_eeprom_image(bytes.fromhex(state["eeprom"]))
        self._poke("model_number", self.model.number)
        self._poke("firmware_version", self._defaults["firmware_version"])
        backup = state.get("backup")
        self._backup = bytes.fromhex(backup) if backup else None
        self.reboot(now)

    # ------------------------------------------------------------------ write rules
    def _check_value(self, name: str, value: int, changes: list[tuple[Item, int]]) -> int:
        def new(n: str) -> int:
            for it, v in changes:
                if it.name == n:
                    return v
            return self._get(n)

        x = self._x
        ranges = {
            "id": (0, 252), "return_delay_time": (0, 254), "status_return_level": (0, 2),
            "torque_enable": (0, 1), "protocol_type": (1, 2), "bus_watchdog": (0, 127),
            "temperature_limit": (0, 100), "startup_configuration": (0, 3),
            "pwm_limit": (0, 885 if x else 2009), "led": (0, 1),
            "external_port_mode_1": (0, 3), "external_port_mode_2": (0, 3),
            "external_port_mode_3": (0, 3), "external_port_mode_4": (0, 3),
            "max_position_limit": (self.model.position_min_pulse, self.model.position_max_pulse),
            "min_position_limit": (self.model.position_min_pulse, self.model.position_max_pulse),
        }
        if x:  # X e-Manual ranges
            ranges.update({name: (0, X_GAIN_MAX) for name in X_GAINS})
            ranges.update({"homing_offset": (-X_HOMING_MAX, X_HOMING_MAX), "moving_threshold": (0, 1023),
                           "profile_acceleration": (0, 32767), "profile_velocity": (0, 32767)})
        if name in ranges:
            lo, hi = ranges[name]
            if not lo <= value <= hi:
                return p.ERR_DATA_RANGE
        if name == "operating_mode" and value not in self.model.operating_modes:
            return p.ERR_DATA_RANGE
        if name == "operating_mode" and value == 0 and math.isnan(self.model.current_ma_per_pulse):
            return p.ERR_DATA_RANGE
        if name == "baud_rate" and value not in self.baud_rates:
            return p.ERR_DATA_RANGE
        if name == "drive_mode" and x and value & ~0x0D:
            return p.ERR_DATA_RANGE
        if name.startswith("goal_") and self._get("bus_watchdog") < 0:
            return p.ERR_DATA_RANGE  # goals are read-only after a bus watchdog error
        if name == "torque_enable" and value == 1 and self._shutdown_latched:
            return p.ERR_RESULT_FAIL
        limits = {"goal_pwm": "pwm_limit", "goal_current": "current_limit",
                  "goal_velocity": "velocity_limit"}
        if name in limits and self._has(limits[name]) and abs(value) > new(limits[name]):
            return p.ERR_DATA_LIMIT
        if name == "goal_position":
            mode = new("operating_mode")
            if mode == 3 and not new("min_position_limit") <= value <= new("max_position_limit"):
                return p.ERR_DATA_LIMIT
            if mode in EXTENDED_MODES and x and abs(value) > X_EXTENDED_GOAL_LIMIT:
                return p.ERR_DATA_LIMIT
        return p.ERR_NONE

    def _apply(self, name: str, value: int, now: float) -> None:
        old = self._get(name)
        self._poke(name, value)
        if name == "torque_enable":
            if value == 1 and old == 0:
                if self._get("operating_mode") == 3:
                    self._motor.p = self._fold(self._motor.p)
                self._hold_if_position_mode()
                self._last_instruction = now
            elif value == 0:
                self._motor.stop()
        elif name == "operating_mode" and value != old:
            for reset in MODE_RESET_ITEMS:
                if reset in self._defaults:
                    self._poke(reset, self._defaults[reset])
            if value == 3:
                self._motor.p = self._fold(self._motor.p)
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

    def _apply_hardware_error(self, bits: int) -> None:
        if bits & self._get("shutdown", 0xFF):
            self._shutdown_latched = True
            self._poke("torque_enable", 0)
            self._motor.stop()
        elif bits == 0:
            self._shutdown_latched = False

    # ------------------------------------------------------------------ frames and physics
    def _sign(self) -> float:
        return -1.0 if self._get("drive_mode") & 0x01 else 1.0

    def _user_position(self) -> float:
        return self._sign() * self._motor.p + self._get("homing_offset")

    def _revolution(self) -> int:
        return 4096 if self._x else 2 * self.model.position_max_pulse

    def _fold(self, raw: float) -> float:
        rev = self._revolution()
        if self._x:
            return raw % rev
        half = rev // 2
        return ((raw + half) % rev) - half

    def _hold_if_position_mode(self) -> None:
        if self._get("operating_mode") in POSITION_MODES:
            self._poke("goal_position", int(round(self._user_position())))

    def _scale(self, kind: str) -> float:
        per = {"v": self.model.velocity_deg_s_per_pulse, "a": self.model.acceleration_deg_ss_per_pulse}[kind]
        return per / self.model.position_deg_per_pulse

    def _threshold_pulses(self) -> float:
        return self._get("moving_threshold") * self._scale("v")

    def _command(self) -> Command:
        torque = self._get("torque_enable") == 1
        mode = self._get("operating_mode")
        s = self._sign()
        vscale, ascale = self._scale("v"), self._scale("a")
        vlim = max(self._get("velocity_limit"), 1) * vscale
        prof_a = self._get("profile_acceleration")
        amax = prof_a * ascale if prof_a > 0 else math.inf
        if mode in POSITION_MODES:
            if self._has("profile_velocity"):
                pv = self._get("profile_velocity")
            else:  # old PRO: Goal Velocity caps the position move
                pv = abs(self._get("goal_velocity"))
            vmax = min(pv * vscale, vlim) if pv > 0 else vlim
            if self._get("drive_mode") & 0x04 and pv > 0:  # time-based profile: ms, not velocity
                span = abs(self._get("goal_position") - self._user_position())
                accel_ms = min(prof_a, pv // 2) if prof_a > 0 else 0
                vmax = min(span / max((pv - accel_ms) / 1000.0, 1e-3), vlim) or vlim
                amax = vmax / (accel_ms / 1000.0) if accel_ms > 0 else math.inf
            target = (self._get("goal_position") - self._get("homing_offset")) * s
            return Command(torque, 0.0, target, vmax, amax)
        if mode == 1:
            return Command(torque, s * self._get("goal_velocity") * vscale, None, vlim, amax)
        if mode == 16:
            full = 885.0 if self._x else 2009.0
            return Command(torque, s * self._get("goal_pwm") / full * vlim, None, vlim, math.inf, LAG_S)
        if mode == 0:
            limit = max(self._get("current_limit"), 1)
            return Command(torque, s * self._get("goal_current") / limit * vlim, None, vlim, math.inf, LAG_S)
        return Command(False)

    def _watchdog_deadline(self) -> float | None:
        wd = self._get("bus_watchdog")
        if self._get("torque_enable") != 1 or not 1 <= wd <= 127:
            return None
        return self._last_instruction + wd * 0.020

    def refresh(self, now: float) -> None:
        """Advance motion to ``now`` and rewrite every present-value register."""
        deadline = self._watchdog_deadline()
        if deadline is not None and deadline < now:
            self._motor.advance(deadline - self._t, self._command())
            self._t = max(self._t, deadline)
            self._trip_watchdog()
        self._motor.advance(now - self._t, self._command())
        self._t = max(self._t, now)
        self._publish(now)

    def _trip_watchdog(self) -> None:
        """The e-Manual: the servo stops and Bus Watchdog reads -1; goals become read-only."""
        self._motor.stop()
        for goal in ("goal_velocity", "goal_pwm", "goal_current"):
            self._poke(goal, 0)
        self._hold_if_position_mode()
        self._poke("bus_watchdog", -1)

    def _publish(self, now: float) -> None:
        m, s = self._motor, self._sign()
        torque = self._get("torque_enable") == 1
        vscale = self._scale("v")
        vlim = max(self._get("velocity_limit"), 1) * vscale
        mode = self._get("operating_mode")
        cmd = self._command()
        position = self._user_position()
        self._poke("present_position", int(round(position)))
        self._poke("position_trajectory", int(round(position)))
        velocity = s * m.v / vscale
        self._poke("present_velocity", int(round(velocity)))
        self._poke("velocity_trajectory", int(round(velocity)))
        frac_v = s * m.v / vlim
        frac_a = max(-1.0, min(1.0, s * m.a / (10.0 * vlim)))
        load = (0.05 * frac_v + 0.3 * frac_a) if torque else 0.0
        limit = self._get("current_limit", 0)
        if mode == 0 and torque:
            current = self._get("goal_current")
        else:
            current = int(round(load * limit))
        self._poke("present_current", current)
        self._poke("present_load", int(round(load * 1000)))
        full = 885 if self._x else 2009
        pwm = self._get("goal_pwm") if (mode == 16 and torque) else int(round((frac_v + 0.1 * frac_a) * full)) if torque else 0
        pwm_limit = self._get("pwm_limit", full)
        self._poke("present_pwm", max(-pwm_limit, min(pwm_limit, pwm)))
        self._poke("present_input_voltage", int(round(self.supply_v * 10)))
        heat = abs(current) / limit if limit else 0.0
        self._poke("present_temperature", self.ambient_c + (2 if torque else 0) + int(round(8 * heat)))
        self._poke("realtime_tick", int((now - self._boot) * 1000) % 32768)
        in_motion = abs(m.v) > self._threshold_pulses()
        ongoing = torque and cmd.target_p is not None and not m.at_target(cmd)
        self._poke("moving", 1 if (in_motion or ongoing) else 0)
        status = 0
        if cmd.target_p is not None and torque:
            if not ongoing:
                status |= 0x01
            else:
                status |= 0x02
                status |= self._profile_kind << 4
        self._poke("moving_status", status)
        for port in self.model.external_ports:
            mode_p = self._get(f"external_port_mode_{port}")
            value = {0: _ANALOG_INPUT, 1: self._port_latch.get(port, 0), 2: 1, 3: 0}.get(mode_p, 0)
            self._poke(f"external_port_data_{port}", value)
        for name, value in self._pinned.items():
            self._poke(name, value)
