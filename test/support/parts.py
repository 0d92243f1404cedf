"""The core's parts built by ``core.parts.build_parts``, the function the Handler builds its own
with, without the Handler: each part over the bus given (a ``FakeBus`` in test/core), with the real
neighbours it calls and its slice of the settings. test/test_unit_coverage.py compares the settings
and the wiring with a Handler's, so a part tested here is the part the Handler runs.

    parts = build(FakeBus({1: XM430}), Settings(), log)
    parts.startup.start(); parts.steps.step()
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

from dynamixel_handler.core.log_limits import LogLimits
from dynamixel_handler.core.parts import PART_NAMES, Parts, build_parts
from dynamixel_handler.core.servo_io import Log
from dynamixel_handler.settings import Settings

__all__ = ["PART_NAMES", "Built", "Parts", "build", "lines_of"]


@dataclass
class Built(Parts):
    """The parts, and what the Handler front adds: the log, the removal line, ``stopping`` (a node
    asked to exit: start-up stops between two servos, mode changes are dropped)."""

    log: Any = None
    stopping: list[bool] = field(default_factory=lambda: [False])

    def say_removed(self, dxl_id: int) -> None:
        self.limited(logging.INFO, f"ID {dxl_id}: removed from the handled servos", f"removed {dxl_id}")

    def __post_init__(self) -> None:
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))


def build(bus: Any, settings: Settings | None = None, log: Log | None = None, *, tripped_once: bool = True) -> Built:
    """The parts over ``bus`` with ``settings`` (default: the defaults), built by the same function
    the Handler builds its parts with (``core.parts.build_parts``), and its removal line."""
    stopping = [False]
    log = log if log is not None else logging.getLogger("parts")
    made = build_parts(bus, settings if settings is not None else Settings(), log, lambda: stopping[0], tripped_once)
    built = Built(**{name: getattr(made, name) for name in PART_NAMES}, log=log, stopping=stopping)
    built.table.watch_removals(built.say_removed)
    return built


def lines_of(name: str, level: int = logging.DEBUG) -> tuple[logging.Logger, list[str]]:
    """A logger of its own for one test, and the lines it gets (``level`` and above)."""
    lines: list[str] = []
    log = logging.getLogger(name)
    log.setLevel(level)
    log.propagate = False
    log.handlers.clear()
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    return log, lines
