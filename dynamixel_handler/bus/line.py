"""``Line``: what the bus needs of the thing under it that moves bytes (the backend).

``DynamixelBus`` is the one implementation of the bus: framing in each servo's protocol, one
transaction at a time, retries, the read left in flight, counters. Under it a line only sends a
packet and hands back the bytes that came in, as python-can's backends ``send`` and receive:

- ``port.SerialPort``: the serial adapter (an exclusive lock on the device, the adapter's latency
  timer, bytes with a deadline in ``select()``);
- ``dummy.InProcessLine``: servos that answer in this process (the dummy servos of
  ``init/dummy_servo_list``), executed by the virtual bus's instruction set with no wire time;
- the tests' ``test/support/memory_line.py`` ``MemoryLine``: servos that are raw register images,
  answered at once by the same instruction sets (``FakeBus`` is a ``DynamixelBus`` over it).

ROS-free.
"""
from __future__ import annotations

from typing import Protocol


class Line(Protocol):
    """A line of servos: bytes out, bytes in by a deadline. ``lost`` is set by the bus when the
    line failed mid-run (the device went away) until it is opened again."""

    device: str
    baudrate: int
    lost: bool

    @property
    def is_open(self) -> bool: ...
    @property
    def effective_latency_ms(self) -> float: ...
    @property
    def tx_ms_per_byte(self) -> float: ...

    def open(self) -> None: ...
    def close(self) -> None: ...
    def set_baudrate(self, baudrate: int) -> None: ...
    def discard_input(self) -> int: ...
    def waiting(self) -> int: ...
    def write(self, packet: bytes) -> None: ...
    def read_until(self, deadline: float, expect: int = 0, due: float | None = None) -> bytes: ...
