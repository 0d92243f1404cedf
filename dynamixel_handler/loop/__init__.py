"""The loop, ROS-free: the scheduler that drives the core's ``Handler`` at ``loop_rate`` on a thread
of its own (``runner``), its statistics line (``stats``) and the timer precision it needs (``timing``).

``from dynamixel_handler.loop import Handler`` (the module this package replaced) still works: the
names it had come from ``core.handler`` when first used; new code imports them from
``dynamixel_handler``."""
from __future__ import annotations

from typing import Any

#: the names the former ``loop`` module gave, all from ``core.handler``
_FORMER = ("EEPROM_WRITE_INTERVAL_S", "Handler", "Interrupted", "RECHECK_LOOPS", "RECONNECT_INTERVAL_S",
           "REBOOT_WAIT_S", "StartupError", "StepReport", "WATCHDOG_MAX_MS", "WATCHDOG_MODES", "WATCHDOG_TRIPPED",
           "mode_value")


def __getattr__(name: str) -> Any:
    if name in _FORMER:
        from ..core import handler
        return getattr(handler, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
