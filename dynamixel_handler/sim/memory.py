"""A virtual servo's life across power cycles: reboot, factory reset, Control Table Backup and
the state a ``--state`` file keeps.

What survives a power cycle is the EEPROM area plus the Indirect Address entries (some of which
lie in RAM addresses on X models); RAM comes back at its factory values.
"""

from __future__ import annotations

from ..protocol import servo as p
from .dynamics import ServoDynamics

BACKUP_KEY = b"CTRL"  # Control Table Backup: 0x01 (store) or 0x02 (restore), then "CTRL"


class ServoMemory(ServoDynamics):
    """Power cycles and the EEPROM image of a virtual servo."""

    _defaults: dict[str, int]
    _backup: bytes | None
    _eeprom_end: int
    _pending: tuple[int, bytes] | None
    eeprom_changed: bool
    partner: ServoMemory | None

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
            self._poke("torque_enable", 1)
            self._torque_changed(0, 1, now)

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
            self._backup = self._file.eeprom_image()
            self._poke("backup_ready", 1)
        elif self._backup is None:
            return p.ERR_RESULT_FAIL
        else:
            keep = {n: self._peek(n) for n in ("id", "model_number", "firmware_version")}
            self._file.load_eeprom_image(self._backup)
            for name, value in keep.items():  # the servo stays where the host reached it
                self._poke(name, value)
        self.eeprom_changed = True
        return p.ERR_NONE

    def state(self) -> dict:
        """What survives a power cycle, as JSON-ready values (the bus's ``--state`` file)."""
        return {"model": self.model.number, "eeprom": self._file.eeprom_image().hex(),
                "backup": self._backup.hex() if self._backup is not None else None}

    def load_state(self, state: dict, now: float) -> None:
        """Power up with a saved EEPROM (and backup), RAM at its defaults."""
        self._file.load_eeprom_image(bytes.fromhex(state["eeprom"]))
        self._poke("model_number", self.model.number)
        self._poke("firmware_version", self._defaults["firmware_version"])
        backup = state.get("backup")
        self._backup = bytes.fromhex(backup) if backup else None
        self.reboot(now)
