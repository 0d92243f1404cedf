"""A servo model (``Model``): its items, the physical unit per pulse of each quantity, its family and
the facts the handler, the baud tool and the simulator read; built by ``control_table``'s builders
(and by a family plug-in's, ``FamilyPlugin``)."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, FrozenSet, Mapping, Optional, Tuple

from ._facts import X330_INDIRECT_DATA_BEFORE_FW52
from ._family import ServoFamily
from ._item import Item
from ._modes import POSITION_LIMITED_MODES

if TYPE_CHECKING:
    from ._protocol1 import LimitModes

OPERATING_MODES: Mapping[str, int] = MappingProxyType({
    "current": 0, "velocity": 1, "position": 3, "ex_position": 4, "cur_position": 5, "pwm": 16,
})


@dataclass(frozen=True)
class Model:
    """A servo model: its items and the physical unit per pulse of each quantity.

    Scales are NaN where the model lacks the quantity (no current sensor on XL430, no PWM on the
    old PRO). Models compare and hash by number and name so they can key caches.
    """

    number: int
    name: str
    #: its family: modes, goal ranges, how topics and parameters name it (``ServoFamily``)
    family: ServoFamily
    items: Mapping[str, Item] = field(repr=False)
    position_deg_per_pulse: float = math.nan
    position_zero_pulse: int = 0
    velocity_deg_s_per_pulse: float = math.nan
    acceleration_deg_ss_per_pulse: float = math.nan
    current_ma_per_pulse: float = math.nan
    pwm_percent_per_pulse: float = math.nan
    voltage_v_per_pulse: float = 0.1
    temperature_degc_per_pulse: float = 1.0
    return_delay_us_per_pulse: float = 2.0
    bus_watchdog_ms_per_pulse: float = 20.0
    realtime_tick_s_per_pulse: float = 0.001
    position_max_pulse: int = 0
    position_min_pulse: int = 0
    external_ports: Tuple[int, ...] = ()
    #: control-table family: "X" (X430/X540), "X330" (X330, XM335), "P" (P and PRO "-RA"), "OLD_PRO"
    layout: str = "X"
    #: Baud Rate register value -> bps
    baud_rates: Mapping[int, int] = field(default_factory=dict, repr=False)
    #: Operating Mode register values the firmware accepts
    operating_modes: Tuple[int, ...] = ()
    #: indirect blocks as (first Indirect Address, first Indirect Data, entries)
    indirect: Tuple[Tuple[int, int, int], ...] = ()
    #: the addresses an Indirect Address may hold (lowest, highest)
    indirect_targets: Tuple[int, int] = (0, 0)
    #: bytes of control table (last address + 1)
    table_size: int = 0
    #: factory (initial) values the e-Manual gives for this model, by item name (limits, gains,
    #: thresholds, shutdown mask...); items it leaves blank are absent
    factory: Mapping[str, int] = field(default_factory=dict, repr=False)
    #: the values the e-Manual allows each item, raw (lowest, highest): its page's ranges (``_ranges``)
    #: and, for an item of ``RANGED_ITEMS`` the manual gives none, the register's byte range
    ranges: Mapping[str, Tuple[int, int]] = field(default_factory=dict, repr=False)
    #: the items of ``ranges`` that keep the register's byte range (the e-Manual gives them none)
    byte_range_items: FrozenSet[str] = frozenset()
    #: operating mode name -> the value of its Operating Mode register (the XL-320's Control
    #: Mode has its own values); a mode a model lacks is absent
    mode_values: Mapping[str, int] = field(default_factory=lambda: OPERATING_MODES, repr=False)
    #: the inverse: register value -> mode name
    mode_names: Mapping[int, str] = field(init=False, repr=False)
    #: the handler switches it only to its own modes (``mode_values``), not to every mode of its
    #: family (MX-28(2.0): no current modes; RH-P12-RN(A): current and current-based position only)
    own_modes: bool = False
    #: the modes whose goal positions stay within the position limits (a gripper's stroke: every
    #: position mode it has)
    position_limited_modes: Tuple[str, ...] = POSITION_LIMITED_MODES
    #: unit per pulse of an item whose scale differs from its quantity's (Y: Present Input Voltage
    #: in 0.01 V, the voltage limits in 0.1 V); NaN: the item has no physical unit
    item_scales: Mapping[str, float] = field(default_factory=dict, repr=False)
    #: EEPROM item -> the RAM item the servo copies it into at power on (XL-320: Max Torque ->
    #: Torque Limit): the handler writes the RAM item too, so a new limit holds at once
    ram_copies: Mapping[str, str] = field(default_factory=dict, repr=False)
    #: items kept in non-volatile memory when written with torque off although writable with torque
    #: on (Y's Hybrid area): the handler writes them only when the value differs
    hybrid_items: FrozenSet[str] = frozenset()
    #: items the host may read but not write (Protocol 1.0 tables say so per item; empty: the
    #: handler's own list of read-only items applies)
    read_only: FrozenSet[str] = frozenset()
    #: the raw value that reads 0 where an item is offset (MX Current: 2048 = 0 mA; EX Sensed
    #: Current: 512 = 0 mA)
    item_zero: Mapping[str, int] = field(default_factory=dict, repr=False)

    @functools.cached_property
    def mode_select(self) -> Optional["LimitModes"]:
        """How the mode is read and set where no Operating Mode register holds it (Protocol 1.0: the
        Angle Limits); None: the Operating Mode register. Its family's behaviour says which."""
        return self.family.behaviour.mode_select(self)

    @property
    def protocol(self) -> int:
        """The Dynamixel protocol the model speaks (its family's): 2, or 1."""
        return self.family.protocol

    def __post_init__(self) -> None:
        object.__setattr__(self, "mode_names", MappingProxyType({v: k for k, v in self.mode_values.items()}))

    @property
    def modes(self) -> FrozenSet[str]:
        """The operating modes (by name) a command may switch it to."""
        return frozenset(self.mode_values) if self.own_modes else self.family.modes

    def mode_name(self, value: Optional[int]) -> Optional[str]:
        """The mode an Operating Mode register value means on this model (None: none or unknown)."""
        return self.mode_names.get(value) if value is not None else None

    def indirect_blocks(self, firmware: int) -> Tuple[Tuple[int, int, int], ...]:
        """The indirect blocks for a firmware version: X330 firmware before v52 had its
        Indirect Data at 224 instead of 208."""
        if self.layout == "X330" and firmware < 52 and self.indirect and self.indirect[0][1] == 208:
            address, _, count = self.indirect[0]
            return ((address, X330_INDIRECT_DATA_BEFORE_FW52, count),)
        return self.indirect

    @property
    def series(self) -> str:
        """The family's name: "X", "P" or "PRO"."""
        return self.family.name

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Model):
            return NotImplemented
        return self.number == other.number and self.name == other.name

    def __hash__(self) -> int:
        return self.number  # cheap: unit conversions hash a tuple of models on every call

    def has(self, name: str) -> bool:
        """True if this model's control table has the item."""
        return name in self.items

    def value_range(self, name: str) -> Tuple[int, int]:
        """The lowest and highest raw value the e-Manual allows item ``name`` on this model (the
        register's bytes where it gives none); KeyError naming the model if it has no such item."""
        item = self.item(name)
        return self.ranges.get(name, (item.min_raw, item.max_raw))

    def item(self, name: str) -> Item:
        """The item by canonical name; KeyError naming the model if it has no such item."""
        try:
            return self.items[name]
        except KeyError:
            raise KeyError(f"{self.name} (model {self.number}) has no control-table item {name!r}") from None
