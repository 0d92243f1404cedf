"""The core's front, ``Handler``, lives in ``core/handler.py``; this name stays for code that
imports it from here (scripts, tests, ``examples/``)."""
from __future__ import annotations

from .core.handler import (
    EEPROM_WRITE_INTERVAL_S,
    REBOOT_WAIT_S,
    RECHECK_LOOPS,
    RECONNECT_INTERVAL_S,
    WATCHDOG_MAX_MS,
    WATCHDOG_MODES,
    WATCHDOG_TRIPPED,
    Handler,
    Interrupted,
    StartupError,
    StepReport,
    mode_value,
)

__all__ = ["EEPROM_WRITE_INTERVAL_S", "Handler", "Interrupted", "RECHECK_LOOPS", "RECONNECT_INTERVAL_S", "REBOOT_WAIT_S",
           "StartupError", "StepReport", "WATCHDOG_MAX_MS", "WATCHDOG_MODES", "WATCHDOG_TRIPPED", "mode_value"]
