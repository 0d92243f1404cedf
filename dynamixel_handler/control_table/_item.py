"""One control-table entry (``Item``): where it lives and how its bytes read."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple


@dataclass(frozen=True)
class Item:
    """One control-table entry: where it lives and how its bytes read."""

    name: str
    address: int
    size: int
    signed: bool
    eeprom: bool
    #: a sign-magnitude item: this bit carries the direction (set: clockwise, negative) and the
    #: bits below it the magnitude (XL-320 speeds and load: bit 10); 0: plain or two's complement
    direction_bit: int = 0
    #: the values the register takes where that is narrower than its bytes (XL-320 positions
    #: 0..1023); None: whatever the bytes hold
    value_range: Optional[Tuple[int, int]] = None

    @property
    def min_raw(self) -> int:
        """Smallest value the item holds (its bytes, or the register's narrower range)."""
        if self.value_range is not None:
            return self.value_range[0]
        if self.direction_bit:
            return -((1 << self.direction_bit) - 1)
        return -(1 << (8 * self.size - 1)) if self.signed else 0

    @property
    def max_raw(self) -> int:
        """Largest value the item holds (its bytes, or the register's narrower range)."""
        if self.value_range is not None:
            return self.value_range[1]
        if self.direction_bit:
            return (1 << self.direction_bit) - 1
        return (1 << (8 * self.size - 1)) - 1 if self.signed else (1 << (8 * self.size)) - 1

    def from_bytes(self, data: "bytes | bytearray") -> int:
        """The value of the item's bytes (little-endian; sign-magnitude where it is such an item)."""
        raw = int.from_bytes(data, "little", signed=self.signed)
        return self.from_unsigned(raw) if self.direction_bit else raw

    def from_unsigned(self, raw: int) -> int:
        """A sign-magnitude register value (as its bytes read unsigned) as a signed number."""
        magnitude = raw & ((1 << self.direction_bit) - 1)
        return -magnitude if raw >> self.direction_bit & 1 else magnitude

    def to_unsigned(self, value: int) -> int:
        """A signed number as a sign-magnitude register value (the magnitude cut to its bits)."""
        magnitude = min(abs(int(value)), (1 << self.direction_bit) - 1)
        return magnitude | (1 << self.direction_bit) if value < 0 else magnitude

    def to_bytes(self, value: int) -> bytes:
        """The item's bytes for ``value``; OverflowError where the item cannot hold it."""
        if self.direction_bit:
            if not self.min_raw <= value <= self.max_raw:
                raise OverflowError(f"{self.name}: {value} outside {self.min_raw}..{self.max_raw}")
            value = self.to_unsigned(value)
        return int(value).to_bytes(self.size, "little", signed=self.signed)
