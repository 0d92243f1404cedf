"""The ``servos`` block of the parameters file on the servos: checked after the scan, applied at
each servo's set-up, put back after what resets the servo's RAM.

Set-up (start-up, ``add_id``, a reconnect), in this order: the EEPROM items with torque off and
only where they differ from what the servo holds (``Deferred.write_eeprom_many``), then the mode
(only if it differs), then (after the start values) gains, profiles and the other RAM items;
each item read back; one line per servo. After a mode change and a reboot (an error clear's too)
the RAM items (gains, profiles, LED) are written again: the firmware put them back to its defaults.
"""
from __future__ import annotations

import logging
from typing import Callable, Sequence

from .. import units
from ..control_table import POSITION_MODES, Model
from ..errors import ConfigError
from ..servo.settings import FIELDS, ServoSetting
from ..servo.table import ServoTable
from ..servo_targets import dangers, refused_fields, register_values
from .deferred import Deferred
from .servo_io import ServoIO
from .watchdog import Watchdog

Say = Callable[[int, str], None]


class KeptSettings:
    """The entries of ``settings()`` (the ``servos`` block) applied to the servos of the table."""

    def __init__(self, table: ServoTable, io: ServoIO, eeprom: Deferred, watchdog: Watchdog,
                 servos: Sequence[ServoSetting], say: Say) -> None:
        self.table = table
        self.io = io
        self.eeprom = eeprom
        self.watchdog = watchdog
        #: the parameters file's servos block (replaced with the settings: ``Parts.apply``)
        self.servos = tuple(servos)
        self.say = say
        #: IDs whose entry was applied at their set-up: what resets their RAM puts it back
        self.applied: set[int] = set()
        #: (ID, model number) -> the entry's fields left out on that model (reported once)
        self.withheld: dict[tuple[int, int], frozenset[str]] = {}

    def entry(self, dxl_id: int) -> ServoSetting | None:
        """The servo's entry, without the items its model refuses or that would lower a protection
        unasked (``debug``, or a servo replaced by another model while unplugged: those are left
        out with one line)."""
        setting = next((s for s in self.servos if s.dxl_id == dxl_id), None)
        if setting is None or dxl_id not in self.table:
            return setting
        model = self.table.model(dxl_id)
        key = (dxl_id, model.number)
        if key not in self.withheld:
            refused = self._refused(model, setting)
            for line in dict.fromkeys(refused.values()):  # a line for several fields of one item: once
                self.say(logging.WARNING, f"{line}: left out")
        left_out = self.withheld[key]
        if not left_out:
            return setting
        return ServoSetting(dxl_id, {f: v for f, v in setting.values.items() if f not in left_out}, setting.name,
                            setting.force)

    def sets(self, dxl_id: int, item: str) -> bool:
        """Whether the servo's entry sets control-table ``item``."""
        entry = self.entry(dxl_id)
        return entry is not None and entry.sets(item)

    # ---------------------------------------------------------------- before anything is written
    def check(self, debug: bool) -> None:
        """Every entry against the servos found: an ID not handled, an item its model lacks, a value
        beyond its e-Manual range, a mode it lacks; then the set-up tool's checks on what it would
        change (``servo_targets.dangers``: min below max, no protection lowered without ``force:
        true``). One ERROR line each, then ConfigError (nothing is written); with ``debug`` the
        lines are warnings, those items are left out and the node runs on."""
        lines = []
        for setting in self.servos:
            if setting.dxl_id not in self.table:
                lines.append(f"servos.{setting.name}: ID {setting.dxl_id} is not on the bus (handled: "
                             f"{list(self.table.ids)}): check the ID, or take the entry out")
                continue
            lines += dict.fromkeys(self._refused(self.table.model(setting.dxl_id), setting).values())
        if not lines:
            return
        if debug:
            for line in lines:
                self.say(logging.WARNING, line + " (debug: left out, running on)")
            return
        if len(lines) == 1:
            raise ConfigError(f"{lines[0]}: nothing was written")
        for line in lines:
            self.say(logging.ERROR, line)
        raise ConfigError(f"the servos block has {len(lines)} refused items (the lines above): nothing was written")

    def _refused(self, model: Model, setting: ServoSetting) -> dict[str, str]:
        """{field: why} the entry's items refused on this servo (kept in ``withheld``): what its
        model lacks or holds beyond its e-Manual range, else the set-up tool's checks on what the
        entry would change, read from the servo first (a line for each protection lowered with
        ``force: true``)."""
        refused = refused_fields(model, setting)
        if not refused:
            held: dict[str, int | None] = {}

            def current(item: str) -> int | None:
                if item not in held:
                    held[item] = self.io.read_item(setting.dxl_id, item) if model.has(item) else None
                return held[item]

            items, forced = dangers(model, setting, current, self.table.ids)
            for line in forced:
                self.say(logging.WARNING, line)
            refused = {f: why for item, why in items.items() for f in setting.values if FIELDS[f].item == item}
        self.withheld[(setting.dxl_id, model.number)] = frozenset(refused)
        return refused

    # ---------------------------------------------------------------- set-up
    def prepare(self, dxl_id: int) -> list[str]:
        """EEPROM items (only those that differ), then the mode, with torque off once for both (on
        again after, safely, if it was on): what was done, for ``finish``."""
        self.applied.discard(dxl_id)
        entry = self.entry(dxl_id)
        if entry is None:
            return []
        model = self.table.model(dxl_id)
        eeprom, before = self._eeprom_of(dxl_id, model, entry)
        mode = entry.values.get("mode")
        change = mode is not None and self.io.mode(dxl_id) != mode
        torque = self.io.torque_off_for_eeprom(dxl_id) if change or eeprom != before else 0
        done = self._write_eeprom(dxl_id, entry, eeprom, before)
        if mode is not None:
            done.append(self._mode(dxl_id, model, mode) if change else f"mode {mode} (already so)")
        if torque:
            self.io.torque_on(dxl_id)
        return done

    def _eeprom_of(self, dxl_id: int, model: Model, entry: ServoSetting) -> tuple[dict[str, int], dict[str, int | None]]:
        """The entry's EEPROM items {item: value} but the mode, and what the servo holds of them."""
        values = self._values(model, entry)
        eeprom = {item: v for item, v in values.items() if item != "operating_mode" and model.item(item).eeprom}
        return eeprom, {item: self.io.read_item(dxl_id, item) for item in eeprom}

    def _write_eeprom(self, dxl_id: int, entry: ServoSetting, eeprom: dict[str, int],
                      before: dict[str, int | None]) -> list[str]:
        written = self.eeprom.write_eeprom_many(dxl_id, eeprom) if eeprom else None
        if written is not None and not written:
            self.say(logging.WARNING, f"ID {dxl_id}: servos.{entry.name}: an EEPROM write failed: {written.why}")
        return [f"{self._field(entry, item)} ({'EEPROM, written' if before[item] != v else 'EEPROM, already so'})"
                for item, v in eeprom.items()]

    def _mode(self, dxl_id: int, model: Model, mode: str) -> str:
        written = self.io.write_item(dxl_id, "operating_mode", model.mode_values[mode])
        if not written:
            self.say(logging.WARNING, f"ID {dxl_id}: mode {mode} not set: {written.why}")
        return f"mode {mode}"

    def finish(self, dxl_id: int, done: list[str]) -> None:
        """RAM items (gains, profiles, LED, bus watchdog), everything read back, one line."""
        entry = self.entry(dxl_id)
        if entry is None:
            return
        model = self.table.model(dxl_id)
        done = done + self._write_ram(dxl_id, model, entry)
        wrong = self._read_back(dxl_id, model, entry)
        self.applied.add(dxl_id)
        self.say(logging.INFO, f"ID {dxl_id} ({model.name}): servos.{entry.name} set: {', '.join(done)}; "
                 + ("read back" if not wrong else f"read back differs: {', '.join(wrong)}"))

    def put_back(self, dxl_id: int, why: str) -> None:
        """After a mode change or a reboot: the entry's RAM items written again, one line."""
        entry = self.entry(dxl_id)
        if entry is None or dxl_id not in self.applied or dxl_id not in self.table:
            return
        done = self._write_ram(dxl_id, self.table.model(dxl_id), entry, quiet=True)
        if done:
            self.say(logging.INFO, f"ID {dxl_id}: servos.{entry.name} put back after {why}: {', '.join(done)}")

    def _write_ram(self, dxl_id: int, model: Model, entry: ServoSetting, quiet: bool = False) -> list[str]:
        done = []
        for item, value in self._values(model, entry).items():
            if item == "operating_mode" or model.item(item).eeprom or self._turns(dxl_id, model, item):
                continue
            if item == "bus_watchdog":
                if not quiet:  # the watchdog part keeps it (armed when the loop starts, again after a reboot)
                    self.watchdog.keep_user(dxl_id, value)
                    done.append(self._field(entry, item))
                continue
            written = self.io.write_item(dxl_id, item, value)
            if written:
                done.append(self._field(entry, item) + _step_note(model, entry, item))
            else:
                self.say(logging.WARNING, f"ID {dxl_id}: servos.{entry.name}: {item} = {value} not written: "
                         f"{written.why}")
        return done

    def _turns(self, dxl_id: int, model: Model, item: str) -> bool:
        """Whether ``item`` is the Moving Speed that carries the entry's speed of a move (Protocol
        1.0, XL-320) while the servo is out of the position modes: there it is the velocity goal,
        and writing the speed would turn the shaft."""
        behaviour = model.family.behaviour
        return (behaviour.speed_in_position_only(model) and item == behaviour.speed_item(model)
                and self.io.mode(dxl_id) not in POSITION_MODES)

    def _read_back(self, dxl_id: int, model: Model, entry: ServoSetting) -> list[str]:
        wrong = []
        for item, value in self._values(model, entry).items():
            if item == "bus_watchdog" or self._turns(dxl_id, model, item):
                continue  # armed when the loop starts; Moving Speed kept for Joint Mode
            got = self.io.read_item(dxl_id, item) if item != "operating_mode" else \
                model.mode_values.get(self.io.mode(dxl_id) or "")
            if got != value:
                wrong.append(f"{item} {got} (not {value})")
        return wrong

    def _values(self, model: Model, entry: ServoSetting) -> dict[str, int]:
        return register_values(model, entry, lambda item: self.io.value(entry.dxl_id, item))

    @staticmethod
    def _field(entry: ServoSetting, item: str) -> str:
        """The entry's fields that go to ``item``, with their values, as the file gives them."""
        names = [f for f in entry.values if FIELDS[f].item == item or _led_of(f, item)]
        return ", ".join(f"{f} {entry.values[f]}" for f in names) or item


def _step_note(model: Model, entry: ServoSetting, item: str) -> str:
    """What a value less than one step of a profile item was written as (never 0: no limit)."""
    for field, value in entry.values.items():
        if FIELDS[field].item == item and isinstance(value, (int, float)) and units.under_one_step(model, item, value):
            step = float(units.pulse_to_unit([model], item, [1])[0])
            return f" (less than one step: written as {step:g}, not as 0, which the servo takes for no limit)"
    return ""


def _led_of(field: str, item: str) -> bool:
    return field.startswith("led.") and item.startswith("led")


__all__ = ["KeptSettings"]
