"""A scripted peer on the far end of a real pty, and the Protocol 2.0 packets it answers with.

The peer records every instruction packet our bus sends and writes back what the test's handler
gives. Packets are built with dynamixel_sdk's own CRC routine (an independent oracle), not ours.
"""
from __future__ import annotations

import os
import select
import threading
import time
from typing import Callable

from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler

_SDK = Protocol2PacketHandler()

#: handler(packet) -> bytes to write back, or floats (seconds to sleep first)
Handler = Callable[[bytes], list]


def sdk_crc(data: bytes) -> int:
    return _SDK.updateCRC(0, list(data), len(data))


def with_crc(packet: bytes) -> bytes:
    crc = sdk_crc(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


def instruction(dxl_id: int, inst: int, params: bytes = b"") -> bytes:
    """An instruction packet as the e-Manual writes it (params here never need stuffing)."""
    length = len(params) + 3
    return with_crc(bytes([0xFF, 0xFF, 0xFD, 0x00, dxl_id, length & 0xFF, length >> 8, inst]) + params)


def status(dxl_id: int, params: bytes = b"", error: int = 0) -> bytes:
    """A status packet as a servo sends it (params here never need stuffing)."""
    length = len(params) + 4
    return with_crc(bytes([0xFF, 0xFF, 0xFD, 0x00, dxl_id, length & 0xFF, length >> 8, 0x55, error]) + params)


def split_packets(buffer: bytearray) -> list[bytes]:
    """The whole packets at the front of ``buffer``, taken out of it."""
    out = []
    while True:
        start = buffer.find(b"\xff\xff\xfd\x00")
        if start < 0 or len(buffer) < start + 7:
            return out
        total = 7 + (buffer[start + 5] | (buffer[start + 6] << 8))
        if len(buffer) < start + total:
            return out
        out.append(bytes(buffer[start:start + total]))
        del buffer[:start + total]


class WirePeer:
    """The far end of a pty: ``received`` holds every instruction packet; ``handler(packet)`` gives
    what is written back (one status packet per answering servo), floats meaning a pause first."""

    def __init__(self, handler: Handler | None = None) -> None:
        self.master, self.slave = os.openpty()
        self.path = os.ttyname(self.slave)
        self.received: list[bytes] = []
        self.handler: Handler = handler or (lambda packet: [])
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
            for packet in split_packets(buffer):
                self.received.append(packet)
                for item in self.handler(packet):
                    if isinstance(item, float):
                        time.sleep(item)
                    else:
                        os.write(self.master, item)

    def send(self, data: bytes) -> None:
        os.write(self.master, data)

    def wait_for(self, count: int, timeout: float = 5.0) -> list[bytes]:
        """The packets received once there are ``count`` (for packets that have no reply)."""
        end = time.monotonic() + timeout
        while len(self.received) < count and time.monotonic() < end:
            time.sleep(0.005)
        return list(self.received)

    def vanish(self) -> None:
        """The device goes: the peer stops and both ends of the pty close."""
        self._stop.set()
        self._thread.join()
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass

    close = vanish
