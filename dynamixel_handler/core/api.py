"""The core as the command side sees it: the one narrow interface commands are written against.

``Commander`` (and the extra and joint commands) check a message and then ask the core through
``core`` (typed calls, ``calls.CoreCalls``); nothing else of the ``Handler`` is theirs to touch.
``core.handler.Handler`` implements it (a runtime-checked test holds them together)."""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Callable, Protocol, runtime_checkable

from ..control_table import Model
from ..servo.table import PendingWrites, ServoTable
from ..settings import Settings
from .calls import CoreCalls

Warn = Callable[[str], None]


@dataclass(frozen=True)
class LoopFigures:
    """What the loop has counted so far, taken at once from the parts that count it."""

    loop_count: int
    #: the loop's measured period (0 before the first loops)
    loop_period_s: float
    #: loops until a silent servo is pinged again
    recheck_loops: int
    device_lost: bool
    device_lost_since: float | None
    reconnects: int
    watchdog_trips: int
    #: why the E-stop is engaged (None: released): moving requests are refused meanwhile
    e_stop: str | None = None


@runtime_checkable
class ServoAccess(Protocol):
    @property
    def log(self) -> logging.Logger | logging.LoggerAdapter[Any]: ...

    # ---------------------------------------------------------------- what is known
    @property
    def settings(self) -> Settings: ...
    @property
    def table(self) -> ServoTable: ...   # read-only here: vectorised look-ups of many servos
    @property
    def handled_ids(self) -> list[int]: ...
    @property
    def pending(self) -> PendingWrites: ...   # read-only here: goals waiting for the next write
    def figures(self) -> LoopFigures: ...   # loop count, measured period, recheck loops, device, trips
    def handles(self, dxl_id: int) -> bool: ...
    def model(self, dxl_id: int) -> Model: ...
    def mode(self, dxl_id: int) -> str | None: ...
    def value(self, dxl_id: int, item: str) -> int | None: ...

    # ---------------------------------------------------------------- requests
    # any thread: a request value queued for the loop thread, taken in order by the part attached for its type
    def submit(self, request: object, what: str = "") -> None: ...
    # loop thread: typed calls, each answering an Answer (True in a condition when done)
    @property
    def core(self) -> CoreCalls: ...
    def read_item(self, dxl_id: int, item: str) -> int | None: ...
