"""The ROS-free loop core (``Handler``) on a virtual bus of its own, for tests that step the loop by
hand and look at the simulated registers and the handler's log lines."""
from __future__ import annotations

import logging
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Mapping

from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.config import defaults, validate
from dynamixel_handler.core.handler import Handler
from dynamixel_handler.sim import VirtualBus

from .ros import SCAN_RETRIES


@contextmanager
def handler_on_virtual_bus(servos: Mapping[int, int], config: Mapping[str, Any] | None = None, *,
                           baudrate: int | None = None, patient: bool = False,
                           retry_num: int = 1, tripped_once: bool = True,
                           latency_timer_ms: float | None = None) -> Iterator[tuple[VirtualBus, Handler]]:
    """A started ``Handler`` for ``servos`` (ID -> model number) with ``config`` over the defaults;
    ``(sim, handler)``. ``baudrate`` None: the servos' factory 57600 bps. ``patient``: a reply
    timeout and retries that a busy host cannot exhaust, for tests comparing two runs reply for
    reply (a lost reply would part them). ``tripped_once`` False: goals look for tripped bus
    watchdogs servo by servo (``Handler``). ``latency_timer_ms``: the adapter's reply wait (a test
    that loses replies on purpose with no retries, and must not lose others to a loaded host). The
    start-up scan expects every servo of ``servos`` and
    retries until it saw them all: a busy host can delay a reply past a 1 ms adapter's timeout."""
    sim = VirtualBus(servos, baudrate=baudrate)
    latency = latency_timer_ms if latency_timer_ms is not None else 16.0 if patient else 1.0
    bus = DynamixelBus(sim.start(), baudrate or 57600, latency_timer_ms=latency,
                       retry_num=3 if patient else retry_num)
    bus.open()
    try:
        handler = Handler(bus, validate({**defaults(), "device_name": sim.path,
                                         "init/servo_auto_search.max_id": max(servos),
                                         "init/expected_servo_num": len(servos),
                                         "init/servo_auto_search.retry_times": SCAN_RETRIES, **(config or {})}),
                          tripped_once=tripped_once)
        handler.start()
        yield sim, handler
    finally:
        bus.close()
        sim.close()


def capture_log(handler: Handler, name: str,
                line: Callable[[logging.LogRecord], str] = logging.LogRecord.getMessage) -> list[str]:
    """The handler's log lines from now on, as ``line`` writes each record (the message alone by default)."""
    lines: list[str] = []
    handler.log = logging.getLogger(name)
    handler.log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(line(r))})())
    return lines
