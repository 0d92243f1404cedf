"""One servo at a time: read or write an item, its mode, torque on without a jump."""
from __future__ import annotations

import logging
from typing import Any

from .. import units
from ..bus import Failure, Result, ServoBus
from ..bus.ops import ErrorByte, Read, Write
from ..control_table import Model
from ..servo import error_state
from ..servo.table import ServoTable

Log = logging.Logger | logging.LoggerAdapter[Any]
#: the item that holds the mode (Protocol 1.0 servos: the Angle Limits stand for it)
MODE = "operating_mode"


class ServoIO:
    """Single-servo reads and writes, kept in the servo table."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        #: Joint Mode's Angle Limits of each Protocol 1.0 servo, as last seen in Joint Mode
        self._joint: dict[int, tuple[int, int]] = {}

    def read_item(self, dxl_id: int, item: str) -> int | None:
        model = self.table.model(dxl_id)
        if item == MODE and model.mode_select is not None:
            return self._read_mode(dxl_id, model)
        if item == model.family.behaviour.status_error_item:  # Protocol 1.0: the status's error byte
            return self._read_status_error(dxl_id, model)
        if not model.has(item):
            return None
        spec = model.item(item)
        data = self.bus.execute(Read(dxl_id, spec.address, spec.size, protocol=model.protocol)).value
        if data is None:
            return None
        value = int(units.decode(spec, data)[0])
        self.table.set_value(item, dxl_id, value)
        return value

    def write_item(self, dxl_id: int, item: str, pulses: int) -> Result[bool]:
        """Write one item of one servo (kept in the table when acknowledged): True, or False and why."""
        model = self.table.model(dxl_id)
        if item == MODE and model.mode_select is not None:
            return self._write_mode(dxl_id, model, pulses)
        if not model.has(item):
            return Result(False, Failure.NO_SUCH_ITEM, f"ID {dxl_id} ({model.name}) has no {item}")
        if item in model.hybrid_items and self.value(dxl_id, item) == pulses:
            return Result(True)  # Y's Hybrid area, stored when torque is off: not written again
        spec = model.item(item)
        written = self.bus.execute(Write(dxl_id, spec.address, units.encode(spec, [pulses]), protocol=model.protocol))
        if written:
            self.table.set_value(item, dxl_id, pulses)
        return written

    def _read_status_error(self, dxl_id: int, model: Model) -> int | None:
        """The error state of a servo that reports it in its status (Protocol 1.0): a ping's error
        byte, the bits of it that are the servo's state (its family's behaviour says which) kept in
        the table as its error item."""
        error: int | None = self.bus.execute(ErrorByte(dxl_id, protocol=model.protocol)).value
        return None if error is None else error_state.keep_status_error(self.table, dxl_id, error)

    def _read_mode(self, dxl_id: int, model: Model) -> int | None:
        """The mode code of a servo whose mode the Angle Limits select (Protocol 1.0), kept in the
        table as its ``operating_mode``."""
        select = model.mode_select
        assert select is not None
        code = select.code({item: self.read_item(dxl_id, item) for item in select.items})
        if code is not None:
            self.table.set_value(MODE, dxl_id, code)
            if model.mode_name(code) == "position":
                self._joint[dxl_id] = (self.table.value("min_position_limit", dxl_id) or 0,
                                       self.table.value("max_position_limit", dxl_id) or 0)
        return code

    def _write_mode(self, dxl_id: int, model: Model, code: int) -> Result[bool]:
        """Switch a servo whose mode the Angle Limits select: the items its mode needs, Joint Mode's
        limits as they were before it left it."""
        select, mode = model.mode_select, model.mode_name(code)
        assert select is not None
        if mode is None:
            return Result(False, Failure.NO_SUCH_ITEM, f"ID {dxl_id} ({model.name}) has no mode {code}")
        if self.value(dxl_id, MODE) == model.mode_values.get("position"):
            self._read_mode(dxl_id, model)  # the joint limits it has now, to come back to
        for item, value in select.writes(mode, self._joint.get(dxl_id)).items():
            written = self.write_item(dxl_id, item, value)
            if not written:
                return written
        self.table.set_value(MODE, dxl_id, code)
        return Result(True)

    def value(self, dxl_id: int, item: str) -> int | None:
        """The item's last known value, read from the servo when none is known."""
        value = self.table.value(item, dxl_id)
        return value if value is not None else self.read_item(dxl_id, item)

    def mode(self, dxl_id: int) -> str | None:
        value = self.table.value(MODE, dxl_id)
        if value is None:
            value = self.read_item(dxl_id, MODE)
        return self.table.model(dxl_id).mode_name(value)

    def torque_on(self, dxl_id: int) -> Result[bool]:
        """Enable torque without a jump: goals := present state (position) or neutral, then enable."""
        mode = self.mode(dxl_id)
        model = self.table.model(dxl_id)
        if mode in ("position", "ex_position", "cur_position"):
            present = self.read_item(dxl_id, "present_position")
            if present is not None:
                if mode == "position":
                    present = self.clip_to_position_limits(dxl_id, present)
                self.write_item(dxl_id, "goal_position", present)
        elif mode == "velocity":
            self.write_item(dxl_id, "goal_velocity", 0)
        elif mode == "current":
            self.write_item(dxl_id, "goal_current", 0)
        elif mode == "pwm":
            self.write_item(dxl_id, "goal_pwm", 0)
        enabled = self.write_item(dxl_id, "torque_enable", 1)
        if not enabled:
            self.log.warning(f"ID {dxl_id} ({model.name}): torque on failed: {enabled.failure}")
        return enabled

    def torque_off(self, dxl_id: int) -> Result[bool]:
        return self.write_item(dxl_id, "torque_enable", 0)

    def torque_off_for_eeprom(self, dxl_id: int) -> int:
        """Torque off before an EEPROM write (operating mode, limits: the servo refuses them with
        torque on); the torque to restore afterwards. A torque read without answer is not taken
        for "off": the torque is switched off all the same and the value last read is restored.
        A torque off without reply is not an end: the servo may have taken it (a lost reply), and
        the EEPROM write after it tells (access error while the torque is on)."""
        torque = self.read_item(dxl_id, "torque_enable")
        unknown = torque is None
        if unknown:
            torque = self.table.value("torque_enable", dxl_id)
        if torque or unknown:
            self.torque_off(dxl_id)
        return torque or 0

    def clip_to_position_limits(self, dxl_id: int, pulses: int) -> int:
        lo = self.table.value("min_position_limit", dxl_id)
        hi = self.table.value("max_position_limit", dxl_id)
        if lo is None:
            lo = self.read_item(dxl_id, "min_position_limit")
        if hi is None:
            hi = self.read_item(dxl_id, "max_position_limit")
        if lo is not None and hi is not None and lo <= hi:
            return min(max(pulses, lo), hi)
        return pulses
