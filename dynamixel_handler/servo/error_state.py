"""A servo's error state whichever way its family reports it: Hardware Error Status bits (X, P,
PRO, XL-320 in its own order), one error code (Y) or the error byte of its status (Protocol 1.0),
decoded by the family's behaviour (``control_table.behaviour``).

The error state the handler publishes is in hardware error bits: a Y error code shows as the bits
it stands for (``control_table._error_codes``: over/low voltage -> input voltage, overheating ->
overheating, overload -> overload, inverter -> electrical shock, encoder/multi-turn/battery/magnet
-> motor encoder, hall sensor -> motor hall sensor); a code with no matching bit (following error,
over speed, position limit reached, bus watchdog, calibration) sets the status's ``error`` flag
and is named in the log. A warning code (battery warning) is logged, not an error.
"""
from __future__ import annotations

import numpy as np

from ..control_table import Model
from ..control_table.behaviour import HARDWARE_ERROR
from .table import ServoTable

__all__ = ["HARDWARE_ERROR", "codes_by_position", "common_array", "common_bits", "describe", "error_item",
           "error_items", "hardware_bits", "in_error", "is_error", "keep_status_error", "own_bits"]


def error_item(model: Model) -> str:
    """The item that holds the model's error state."""
    return model.family.behaviour.error_item


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
    XL-320 has its own order (overload 0, overheating 1, input voltage 2), Protocol 1.0 another."""
    return model.family.behaviour.common_bits(bits)


def own_bits(model: Model, common: int) -> int:
    """``common_bits`` the other way: bits of the X and P layout as the model's register holds them."""
    return model.family.behaviour.own_bits(common)


def common_array(models: list[Model], values: np.ndarray) -> np.ndarray:
    """``common_bits`` for a table's array of bits (a copy where a model's layout moves a bit)."""
    out = values
    for pos in np.flatnonzero(values):
        bits = models[pos].family.behaviour.common_bits(int(values[pos]))
        if bits != values[pos]:
            if out is values:
                out = np.array(values, dtype=np.int64)
            out[pos] = bits
    return out


def hardware_bits(table: ServoTable) -> np.ndarray:
    """Hardware error bits per servo (0 where unknown): read, or what an error code stands for, in
    the X and P layout."""
    bits = np.where(table.known(HARDWARE_ERROR), table.pulses(HARDWARE_ERROR), 0).astype(np.int64)
    bits = common_array(table.models, bits)
    for pos, code, model in _codes_of(table):
        bits[pos] |= model.family.behaviour.hardware_bits(code)
    return bits


def in_error(table: ServoTable) -> np.ndarray:
    """Per servo: a hardware error bit is set or an error code (not a warning) is held."""
    flags: np.ndarray = np.asarray(hardware_bits(table) != 0)
    for pos, code, model in _codes_of(table):
        if model.family.behaviour.is_error(code):
            flags[pos] = True
    return flags


def is_error(model: Model, value: int | None) -> bool:
    """An error item's value is an error (bits set, or an error code other than a warning)."""
    return model.family.behaviour.is_error(value)


def describe(model: Model, value: int) -> str:
    """The value of the model's error item, named: "error code 5 (Overload Error)" or "0x24"."""
    return model.family.behaviour.describe(value)


def keep_status_error(table: ServoTable, dxl_id: int, error: int) -> int:
    """A status error byte that came with a read (Protocol 1.0), kept as the servo's error state: the
    bits of it its family's behaviour says are the servo's state (``status_state``); those bits."""
    behaviour = table.model(dxl_id).family.behaviour
    state = behaviour.status_state(error)
    table.set_value(behaviour.error_item, dxl_id, state)
    return state


def codes_by_position(table: ServoTable) -> dict[int, str]:
    """Position -> the error code held there, named (servos with an error code other than 0)."""
    out = {}
    for pos, code, model in _codes_of(table):
        out[pos] = describe(model, code)
    return out
