"""Fixtures for the virtual-bus tests: buses on real ptys, the real dynamixel_sdk as host."""

from __future__ import annotations

import os
import select
import termios
import tty

import pytest
from dynamixel_sdk import PacketHandler, PortHandler

from dynamixel_handler.sim import VirtualBus

from support.sdk import PatientPort


class ManualClock:
    """A clock the test advances by hand, so physics is deterministic."""

    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t

    def advance(self, dt: float) -> None:
        self.t += dt


@pytest.fixture
def manual_clock() -> ManualClock:
    return ManualClock()


#: the servos at the hosts' 1 Mbps, replies untimed (speed); a test may ask for the defaults
FAST = {"baudrate": 1_000_000, "wire_timing": False}


@pytest.fixture
def make_bus():
    """Factory: make_bus({id: model}, **kwargs) -> started VirtualBus, closed at teardown. Unless
    given, the servos are at 1 Mbps and the wire untimed (``FAST``)."""
    buses: list[VirtualBus] = []

    def factory(servos, **kwargs) -> VirtualBus:
        bus = VirtualBus(servos, **{**FAST, **kwargs})
        bus.start()
        buses.append(bus)
        return bus

    yield factory
    for bus in buses:
        bus.close()


@pytest.fixture
def make_sdk():
    """Factory: make_sdk(path) -> (PortHandler, PacketHandler) opened at 1 Mbps; the port waits for
    replies as long as a loaded machine needs (``PatientPort``)."""
    ports: list[PortHandler] = []

    def factory(path: str, baudrate: int = 1_000_000):
        port = PatientPort(path)
        assert port.openPort()
        assert port.setBaudRate(baudrate)
        ports.append(port)
        return port, PacketHandler(2.0)

    yield factory
    for port in ports:
        try:
            port.closePort()
        except Exception:
            pass


class RawPort:
    """The host side of the pty without any library: bytes in, bytes out."""

    def __init__(self, path: str, baudrate: int = termios.B1000000) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        attrs = termios.tcgetattr(self.fd)
        attrs[4] = attrs[5] = baudrate  # the servos' 1 Mbps (they hear only their own baud rate)
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)

    def exchange(self, request: bytes, expect: int, timeout: float = 1.0) -> bytes:
        """Send ``request``; return what arrives until ``expect`` bytes or ``timeout``."""
        os.write(self.fd, request)
        return self.receive(expect, timeout)

    def receive(self, expect: int, timeout: float = 1.0) -> bytes:
        out = b""
        while len(out) < expect:
            ready, _, _ = select.select([self.fd], [], [], timeout)
            if not ready:
                break
            out += os.read(self.fd, 4096)
        return out

    def close(self) -> None:
        os.close(self.fd)


@pytest.fixture
def make_raw():
    raws: list[RawPort] = []

    def factory(path: str) -> RawPort:
        raw = RawPort(path)
        raws.append(raw)
        return raw

    yield factory
    for raw in raws:
        raw.close()
