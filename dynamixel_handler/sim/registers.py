"""A servo's control table as bytes: items, indirect addressing, and which bytes a write touches.

The firmware keeps the control table as one byte array; hosts read and write arbitrary spans of
it. Indirect Data bytes are windows onto other addresses: each Indirect Address entry holds the
address its Data byte stands for, so a read or write of Indirect Data goes to that address, and a
Sync/Bulk transfer over the Data block reaches scattered items in one span. An entry that points
at its own Data byte (the factory value) makes that byte plain storage.
"""

from __future__ import annotations

from dynamixel_handler.control_table import Item, Model

from ..protocol import servo as p


class RegisterFile:
    """The bytes of one servo's control table, with the item that owns each address."""

    def __init__(self, model: Model, firmware: int) -> None:
        self.model = model
        self.blocks = model.indirect_blocks(firmware)
        self.items: list[Item] = sorted(model.items.values(), key=lambda it: it.address)
        #: Indirect Address entries (EEPROM: written with torque off, kept over a reboot)
        self.indirect_addresses: list[Item] = []
        #: Indirect Data bytes -> the Indirect Address entry that maps them
        self._map: dict[int, Item] = {}
        for first_address, first_data, count in self.blocks:
            for k in range(count):
                entry = Item(f"indirect_address_{first_address + 2 * k}", first_address + 2 * k, 2, False, True)
                self.indirect_addresses.append(entry)
                self._map[first_data + k] = entry
        end = max([it.address + it.size for it in self.items] + [a + 1 for a in self._map] + [model.table_size])
        self.regs = bytearray(end)
        self.owner: list[Item | None] = [None] * end
        for it in self.items + self.indirect_addresses:
            for a in range(it.address, it.address + it.size):
                self.owner[a] = it
        self._data_lo = min(self._map, default=end)
        self._data_hi = max(self._map, default=-1)
        #: first RAM address: the bytes below are the EEPROM area
        self.eeprom_end = min((it.address for it in self.items if not it.eeprom), default=end)

    # ------------------------------------------------------------------ values
    def peek(self, it: Item) -> int:
        return it.from_bytes(self.regs[it.address:it.address + it.size])

    def poke(self, it: Item, value: int) -> None:
        mask = (1 << (8 * it.size)) - 1
        raw = it.to_unsigned(value) if it.direction_bit else int(value)
        self.regs[it.address:it.address + it.size] = (raw & mask).to_bytes(it.size, "little")

    def factory_indirect(self) -> None:
        """Every Indirect Address points at its own Data byte (plain storage), as shipped."""
        for data, entry in self._map.items():
            self.poke(entry, data)

    def clear_loose_bytes(self) -> None:
        """Every byte that no item owns and that is no Indirect Data byte back to 0."""
        for a, owner in enumerate(self.owner):
            if owner is None and a not in self._map:
                self.regs[a] = 0

    def eeprom_image(self) -> bytes:
        """The bytes a backup (and a state file) keeps: the EEPROM area and the Indirect
        Address entries that lie beyond it."""
        out = bytearray(self.regs[:self.eeprom_end])
        for it in self.indirect_addresses:
            if it.address >= self.eeprom_end:
                out += self.regs[it.address:it.address + it.size]
        return bytes(out)

    def load_eeprom_image(self, image: bytes) -> None:
        """Put back what ``eeprom_image`` returned."""
        self.regs[:self.eeprom_end] = image[:self.eeprom_end]
        k = self.eeprom_end
        for it in self.indirect_addresses:
            if it.address >= self.eeprom_end:
                self.regs[it.address:it.address + it.size] = image[k:k + it.size]
                k += it.size

    def is_indirect_data(self, address: int) -> bool:
        return address in self._map

    def resolve(self, address: int) -> int:
        """Where a byte really lives: an Indirect Data byte goes to the address its entry holds."""
        entry = self._map.get(address)
        if entry is None:
            return address
        target = self.peek(entry)
        return target if 0 <= target < len(self.regs) and target not in self._map else address

    def _touches_indirect(self, address: int, length: int) -> bool:
        return address <= self._data_hi and address + length > self._data_lo

    # ------------------------------------------------------------------ host access
    def read(self, address: int, length: int) -> bytes | None:
        """The bytes a Read of ``length`` at ``address`` returns; None beyond the table."""
        if length < 0 or address < 0 or address + length > len(self.regs):
            return None
        if not self._touches_indirect(address, length):
            return bytes(self.regs[address:address + length])
        return bytes(self.regs[self.resolve(a)] for a in range(address, address + length))

    def gather(self, address: int, data: bytes) -> tuple[int, list[tuple[Item, int]], list[tuple[int, int]]]:
        """The items a write of ``data`` at ``address`` sets: (error, [(item, value)], [(address,
        byte)] for plain Indirect Data storage). Every item touched must be written whole."""
        if not data or address < 0 or address + len(data) > len(self.regs):
            return p.ERR_ACCESS, [], []
        targets = self._targets(address, data)
        raw = [(a, targets[a]) for a in sorted(targets) if self.owner[a] is None and a in self._map]
        changes = self._item_values(targets)
        if changes is None:
            return p.ERR_DATA_LENGTH, [], []
        if not changes and not raw:
            return p.ERR_ACCESS, [], []
        return p.ERR_NONE, changes, raw

    def _targets(self, address: int, data: bytes) -> dict[int, int]:
        """Address -> byte a write sets, Indirect Data bytes resolved to where they point."""
        if self._touches_indirect(address, len(data)):
            return {self.resolve(address + k): b for k, b in enumerate(data)}
        return {address + k: b for k, b in enumerate(data)}

    def _item_values(self, targets: dict[int, int]) -> list[tuple[Item, int]] | None:
        """(item, value) for every item the target bytes touch; None if one is not written whole."""
        changes: list[tuple[Item, int]] = []
        for it in self._owners(targets):
            span = range(it.address, it.address + it.size)
            if any(b not in targets for b in span):
                return None
            changes.append((it, it.from_bytes(bytes(targets[b] for b in span))))
        return changes

    def _owners(self, targets: dict[int, int]) -> list[Item]:
        """The items owning the target addresses, each once, by address."""
        found: dict[int, Item] = {}
        for a in sorted(targets):
            it = self.owner[a]
            if it is not None:
                found.setdefault(it.address, it)
        return list(found.values())


class Registers:
    """A servo's values by item name over its ``RegisterFile``: what every part of a virtual servo
    shares (its model, the X-table flag, the baud rates it knows)."""

    def __init__(self, model: Model, file: RegisterFile, x_table: bool) -> None:
        self.model = model
        self.file = file
        self.regs = file.regs
        #: the model uses the X series' control table rules (ranges, folding, PWM scale)
        self.x = x_table
        self.baud_rates = dict(model.baud_rates)

    def peek(self, name: str) -> int:
        it = self.model.item(name)
        return it.from_bytes(self.regs[it.address:it.address + it.size])

    def poke(self, name: str, value: int) -> None:
        if not self.model.has(name):
            return
        it = self.model.item(name)
        mask = (1 << (8 * it.size)) - 1
        raw = it.to_unsigned(value) if it.direction_bit else int(value)
        self.regs[it.address:it.address + it.size] = (raw & mask).to_bytes(it.size, "little")

    def has(self, name: str) -> bool:
        return self.model.has(name)

    def get(self, name: str, default: int = 0) -> int:
        return self.peek(name) if self.model.has(name) else default
