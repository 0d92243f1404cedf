"""A servo's error state whichever way its family reports it: Hardware Error Status bits (X, P,
PRO) or one error code (Y, ``ServoFamily.error_codes``).

The error state the handler publishes is in hardware error bits: a Y error code shows as the bits
it stands for (``control_table._error_codes``: over/low voltage -> input voltage, overheating ->
overheating, overload -> overload, inverter -> electrical shock, encoder/multi-turn/battery/magnet
-> motor encoder, hall sensor -> motor hall sensor); a code with no matching bit (following error,
over speed, position limit reached, bus watchdog, calibration) sets the status's ``error`` flag
and is named in the log. A warning code (battery warning) is logged, not an error.
"""
from __future__ import annotations

import numpy as np

from .. import units
from ..control_table import Model
from ..protocol import protocol1
from .table import ServoTable

HARDWARE_ERROR = "hardware_error_status"


def error_item(model: Model) -> str:
    """The item that holds the model's error state."""
    codes = model.family.error_codes
    return codes.item if codes is not None else HARDWARE_ERROR


def error_items(models: list[Model]) -> set[str]:
    """The error items of these models."""
    return {error_item(m) for m in models}


def _codes_of(table: ServoTable) -> list[tuple[int, int, Model]]:
    """(position, code, model) of each servo with an error code read and not 0."""
    out = []
    for item in error_items(table.models) - {HARDWARE_ERROR}:
        known, pulses = table.known(item), table.pulses(item)
        for pos in np.flatnonzero(known & (pulses != 0)):
            out.append((int(pos), int(pulses[pos]), table.models[pos]))
    return out


def common_bits(model: Model, bits: int) -> int:
    """Hardware Error Status (or Shutdown) bits in the X and P layout the handler decodes: the
    XL-320 has its own order (``ServoFamily.error_bits``: overload 0, overheating 1, input voltage 2)."""
    layout = model.family.error_bits
    if not layout or not bits:
        return bits
    return units.encode_shutdown(**{f"{name}_error": bool(bits >> bit & 1) for name, bit in layout})


def own_bits(model: Model, common: int) -> int:
    """``common_bits`` the other way: bits of the X and P layout as the model's register holds them."""
    layout = model.family.error_bits
    if not layout:
        return common
    flags = units.decode_shutdown([common])
    return sum(1 << bit for name, bit in layout if flags[f"{name}_error"][0])


def common_array(models: list[Model], values: np.ndarray) -> np.ndarray:
    """``common_bits`` for a table's array of bits (a copy where a model has its own layout)."""
    own = [pos for pos, m in enumerate(models) if m.family.error_bits]
    if not own:
        return values
    out = np.array(values, dtype=np.int64)
    for pos in own:
        out[pos] = common_bits(models[pos], int(out[pos]))
    return out


def hardware_bits(table: ServoTable) -> np.ndarray:
    """Hardware error bits per servo (0 where unknown): read, or what an error code stands for, in
    the X and P layout."""
    bits = np.where(table.known(HARDWARE_ERROR), table.pulses(HARDWARE_ERROR), 0).astype(np.int64)
    bits = common_array(table.models, bits)
    for pos, code, model in _codes_of(table):
        codes = model.family.error_codes
        if codes is not None:
            bits[pos] |= codes.bits(code)
    return bits


def in_error(table: ServoTable) -> np.ndarray:
    """Per servo: a hardware error bit is set or an error code (not a warning) is held."""
    flags: np.ndarray = np.asarray(hardware_bits(table) != 0)
    for pos, code, model in _codes_of(table):
        codes = model.family.error_codes
        if codes is not None and codes.is_error(code):
            flags[pos] = True
    return flags


def is_error(model: Model, value: int | None) -> bool:
    """An error item's value is an error (bits set, or an error code other than a warning)."""
    if not value:
        return False
    codes = model.family.error_codes
    return codes.is_error(value) if codes is not None else True


def describe(model: Model, value: int) -> str:
    """The value of the model's error item, named: "error code 5 (Overload Error)" or "0x24"."""
    codes = model.family.error_codes
    if model.family.error_in_status:
        return protocol1.error_text(value)
    if codes is None:
        return f"0x{value:02X}"
    return f"error code {value} ({codes.name(value)})"


def codes_by_position(table: ServoTable) -> dict[int, str]:
    """Position -> the error code held there, named (servos with an error code other than 0)."""
    out = {}
    for pos, code, model in _codes_of(table):
        out[pos] = describe(model, code)
    return out
