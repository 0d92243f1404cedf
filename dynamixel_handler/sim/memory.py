"""A virtual servo's memory across power cycles: RAM back to its factory values, factory reset,
Control Table Backup and the state a ``--state`` file keeps.

What survives a power cycle is the EEPROM area plus the Indirect Address entries (some of which
lie in RAM addresses on X models); RAM comes back at its factory values.
"""

from __future__ import annotations

from ..protocol import servo as p
from .defaults import MODE_RESET_ITEMS
from .registers import Registers

BACKUP_KEY = b"CTRL"  # Control Table Backup: 0x01 (store) or 0x02 (restore), then "CTRL"


class Memory:
    """The register file's power cycles and EEPROM image; ``defaults``: the factory values."""

    def __init__(self, registers: Registers, defaults: dict[str, int]) -> None:
        self._r = registers
        self.defaults = defaults
        self._backup: bytes | None = None

    def power_cycle(self) -> None:
        """RAM back to its defaults; EEPROM, the Indirect Address entries and a backup are kept."""
        r, file = self._r, self._r.file
        ram_start = file.eeprom_end
        kept = [(it, file.peek(it)) for it in file.indirect_addresses]
        r.regs[ram_start:] = bytes(len(r.regs) - ram_start)
        for it, value in kept:
            file.poke(it, value)
        for name, value in self.defaults.items():
            if r.model.item(name).address >= ram_start:
                r.poke(name, value)
        r.poke("backup_ready", 1 if self._backup is not None else 0)
        for eeprom, ram in r.model.ram_copies.items():  # XL-320: Torque Limit := Max Torque
            r.poke(ram, r.peek(eeprom))

    def mode_changed(self) -> None:
        """The e-Manual: a new operating mode puts gains and profiles back to their defaults (not
        those Y keeps in its Hybrid area)."""
        for name in MODE_RESET_ITEMS:
            if name in self.defaults and name not in self._r.model.hybrid_items:
                self._r.poke(name, self.defaults[name])

    def factory_values(self, option: int) -> None:
        """Factory Reset's values: 0x01 keeps the ID, 0x02 the ID and the Baud Rate, 0xFF nothing
        (the ID becomes 1); bytes no item owns (which a Protocol 1.0 host may write) back to 0. The
        caller power-cycles the servo after it."""
        keep = {}
        if option in (0x01, 0x02):
            keep["id"] = self._r.peek("id")
        if option == 0x02:
            keep["baud_rate"] = self._r.peek("baud_rate")
        for name, value in self.defaults.items():
            self._r.poke(name, keep.get(name, 1 if name == "id" else value))
        self._r.file.factory_indirect()
        self._r.file.clear_loose_bytes()

    def backup(self, params: bytes) -> int:
        """Control Table Backup (0x20): 0x01 "CTRL" stores the EEPROM area, 0x02 "CTRL" puts it
        back. Models without Backup Ready do not know the instruction; torque must be off."""
        r = self._r
        if not r.model.has("backup_ready"):
            return p.ERR_INSTRUCTION
        if len(params) != 5 or params[1:] != BACKUP_KEY or params[0] not in (0x01, 0x02):
            return p.ERR_DATA_RANGE
        if r.peek("torque_enable") == 1:
            return p.ERR_ACCESS
        if params[0] == 0x01:
            self._backup = r.file.eeprom_image()
            r.poke("backup_ready", 1)
        elif self._backup is None:
            return p.ERR_RESULT_FAIL
        else:
            keep = {n: r.peek(n) for n in ("id", "model_number", "firmware_version")}
            r.file.load_eeprom_image(self._backup)
            for name, value in keep.items():  # the servo stays where the host reached it
                r.poke(name, value)
        return p.ERR_NONE

    def state(self) -> dict:
        """What survives a power cycle, as JSON-ready values (the bus's ``--state`` file)."""
        return {"protocol": self._r.model.protocol, "model": self._r.model.number,
                "eeprom": self._r.file.eeprom_image().hex(),
                "backup": self._backup.hex() if self._backup is not None else None}

    def load(self, state: dict) -> None:
        """A saved EEPROM (and backup); the caller power-cycles the servo after it."""
        self._r.file.load_eeprom_image(bytes.fromhex(state["eeprom"]))
        self._r.poke("model_number", self._r.model.number)
        self._r.poke("firmware_version", self.defaults["firmware_version"])
        backup = state.get("backup")
        self._backup = bytes.fromhex(backup) if backup else None
