"""Fixtures for the unit tests of the bus parts: a scripted peer on the far end of a real pty
(it records each instruction packet and answers with bytes the test gives) and a ``Transport``
opened on it. Packets are checked against dynamixel_sdk's CRC routine, not our own."""
from __future__ import annotations

import os
import select
import threading
import time
from typing import Callable, Iterator

import pytest
from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler

from dynamixel_handler.bus.transport import Transport

_SDK = Protocol2PacketHandler()


def with_crc(packet: bytes) -> bytes:
    crc = _SDK.updateCRC(0, list(packet), len(packet))
    return packet + bytes([crc & 0xFF, crc >> 8])


def instruction(dxl_id: int, inst: int, params: bytes = b"") -> bytes:
    """An instruction packet as the e-Manual writes it (params here never need stuffing)."""
    length = len(params) + 3
    return with_crc(bytes([0xFF, 0xFF, 0xFD, 0x00, dxl_id, length & 0xFF, length >> 8, inst]) + params)


def status(dxl_id: int, params: bytes = b"", error: int = 0) -> bytes:
    """A status packet as a servo sends it."""
    length = len(params) + 4
    return with_crc(bytes([0xFF, 0xFF, 0xFD, 0x00, dxl_id, length & 0xFF, length >> 8, 0x55, error]) + params)


Answer = Callable[[bytes], list[bytes]]


class Peer:
    """The far end of a pty: ``received`` holds every instruction packet, ``answer(packet)`` gives
    the bytes written back (a list: one status packet per answering servo)."""

    def __init__(self, answer: Answer) -> None:
        self.master, self.slave = os.openpty()
        self.path = os.ttyname(self.slave)
        self.answer = answer
        self.received: list[bytes] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        buffer = bytearray()
        while not self._stop.is_set():
            try:
                if not select.select([self.master], [], [], 0.02)[0]:
                    continue
                buffer += os.read(self.master, 4096)
            except OSError:
                return
            while (start := buffer.find(b"\xff\xff\xfd\x00")) >= 0 and len(buffer) >= start + 7:
                total = 7 + (buffer[start + 5] | (buffer[start + 6] << 8))
                if len(buffer) < start + total:
                    break
                packet = bytes(buffer[start:start + total])
                del buffer[:start + total]
                self.received.append(packet)
                for reply in self.answer(packet):
                    os.write(self.master, reply)

    def wait_for(self, count: int, timeout: float = 5.0) -> list[bytes]:
        """The packets received once there are ``count`` (for packets that have no reply)."""
        end = time.monotonic() + timeout
        while len(self.received) < count and time.monotonic() < end:
            time.sleep(0.005)
        return list(self.received)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture
def line() -> Iterator[Callable[..., tuple[Peer, Transport]]]:
    """Factory: line(answer, **transport_kwargs) -> (peer, opened Transport). The adapter latency
    is 1 ms and retries are 1 ms apart unless given (short waits for silent servos)."""
    made: list[tuple[Peer, Transport]] = []

    def make(answer: Answer = lambda packet: [], **kwargs) -> tuple[Peer, Transport]:
        peer = Peer(answer)
        transport = Transport(peer.path, **{"baudrate": 1_000_000, "latency_timer_ms": 1.0,
                                            "retry_interval_ms": 1.0, **kwargs})
        transport.open()
        made.append((peer, transport))
        return peer, transport

    yield make
    for peer, transport in made:
        transport.close()
        peer.close()
