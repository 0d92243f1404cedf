"""Values as a person reads them: a number with sensible digits (``3209 mA``, not ``3.209e+03``),
codes by name (``baud_rate = 1,000,000 bps (3)``, ``operating_mode = position (3)``) and bit masks
by their bits (``hardware_error_status = overload, overheating (0x24)``); and one shape for a servo
in every verb's JSON (``id``, ``model``, ``model_number``, ``baudrate``)."""
from __future__ import annotations

import math
from typing import Any, Callable

from ..control_table import Item, Model
from ..protocol import protocol1 as p1
from ..protocol.framers import FRAMERS, PROTOCOL1, PROTOCOL2, Framer

__all__ = ["number", "coded", "named", "servo_doc"]

#: Hardware Error Status and Shutdown bits (ROBOTIS e-Manual), the highest first
_ERROR_BITS = ((5, "overload"), (4, "electrical_shock"), (3, "motor_encoder"), (2, "overheating"),
               (1, "motor_hall_sensor"), (0, "input_voltage"))


def number(value: float, digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits, never in exponent form, trailing zeros cut,
    thousands grouped from 10,000 on: 169.98 -> ``170``, 3209.17 -> ``3209``, 22740 -> ``22,740``."""
    if not math.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    decimals = max(0, digits - 1 - math.floor(math.log10(abs(value))))
    text = f"{value:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    if text in ("-0", ""):
        return "0"
    if abs(value) >= 10_000 and "." not in text:
        text = f"{int(text):,}"
    return text


def bits(raw: int) -> str:
    """``overload, overheating (0x24)``; ``none (0x00)`` when no bit is set."""
    names = [name for bit, name in _ERROR_BITS if raw >> bit & 1]
    other = raw & ~sum(1 << bit for bit, _ in _ERROR_BITS)
    if other:
        names.append(f"other bits 0x{other:02X}")
    return f"{', '.join(names) or 'none'} (0x{raw:02X})"


def coded(model: Model, item: Item, raw: int) -> str | None:
    """The text of a code or bit mask item (baud rate, operating mode, error bits); None for others."""
    if item.name == "baud_rate":
        bps = model.baud_rates.get(raw)
        return f"{bps:,} bps ({raw})" if bps is not None else f"{raw} (no baud rate of {model.name})"
    if item.name == "operating_mode" and model.mode_name(raw):
        return f"{model.mode_name(raw)} ({raw})"
    shown = _BIT_ITEMS[FRAMERS[model.protocol]].get(item.name)
    return shown(raw) if shown is not None else None


def bits1(raw: int) -> str:
    """Protocol 1.0 error bits by name, the highest first: ``overload, overheating (0x24)``."""
    names = [name.replace(" ", "_") for bit, name in reversed(list(enumerate(p1.ERROR_BITS))) if raw >> bit & 1]
    other = raw & ~((1 << len(p1.ERROR_BITS)) - 1)
    if other:
        names.append(f"other bits 0x{other:02X}")
    return f"{', '.join(names) or 'none'} (0x{raw:02X})"


#: the bit mask items of a model, by its protocol's framer, and how their bits read: Hardware Error
#: Status and Shutdown in the X layout; a Protocol 1.0 model's Shutdown and Alarm LED hold the
#: status error bits
_BIT_ITEMS: dict[Framer, dict[str, Callable[[int], str]]] = {
    PROTOCOL2: {"hardware_error_status": bits, "shutdown": bits},
    PROTOCOL1: {"hardware_error_status": bits, "shutdown": bits1, "alarm_led": bits1},
}


def named(model: Model, item: Item, raw: int) -> str:
    """A code or bit mask's name without its register value (``1,000,000 bps``, ``position``,
    ``overload, overheating``); "" for other items."""
    text = coded(model, item, raw)
    return text.rsplit(" (", 1)[0] if text is not None else ""


def servo_doc(dxl_id: int, model: Model | None, baudrate: int, **more: Any) -> dict[str, Any]:
    """One servo in the JSON of every verb: the same keys for who it is, then the verb's own."""
    doc: dict[str, Any] = {"id": dxl_id, "model": model.name if model is not None else None,
                           "model_number": model.number if model is not None else None, "baudrate": baudrate}
    doc.update(more)
    return doc
