"""Opening the bus for the tool: the device as the handler takes it (a tty, a by-id link or
``serial:<USB serial>``) and the exclusive lock every ``DynamixelBus`` takes on it.

While a handler runs it holds that lock, so the tool refuses with one line naming the program, its
pid and how to stop it, instead of reading half of the handler's replies; a second tool is refused
the same way.
"""
from __future__ import annotations

import os

from ..bus import BusError, DynamixelBus
from ..errors import StartupError
from ..serial_ports import resolve
from . import safety
from .errors import StepFailed

__all__ = ["DEFAULT_DEVICE", "open_bus"]

#: the device when ``--device`` is not given (the environment variable ``DXL_DEVICE`` wins)
DEFAULT_DEVICE = "/dev/ttyUSB0"


def default_device() -> str:
    return os.environ.get("DXL_DEVICE") or DEFAULT_DEVICE


#: the handler's words for its parameter -> the tool's option (the bus layer speaks for the node)
_OWN_WORDS = (("the device_name parameter", "--device"), ("point device_name at", "point --device at"),
              ("device_name '", "--device '"), ("device_name", "--device"))


def own_words(text: str) -> str:
    """A message of the bus layer in the tool's words: ``--device``, not the node's ``device_name``."""
    for theirs, ours in _OWN_WORDS:
        text = text.replace(theirs, ours)
    return text


def open_bus(device: str, baudrate: int, latency_ms: float, retries: int) -> DynamixelBus:
    """The open bus at ``baudrate``; StepFailed with the reason (busy: who holds it) otherwise."""
    try:
        path, _chosen = resolve(device)
    except StartupError as exc:
        raise StepFailed(own_words(str(exc))) from None
    bus = DynamixelBus(path, baudrate, latency_timer_ms=latency_ms, retry_num=retries, retry_interval_ms=2.0)
    try:
        bus.open()
    except BusError as exc:
        raise StepFailed(own_words(str(exc))) from None
    safety.install(bus)  # from here a signal stops the tool, after the critical step in progress
    return bus
