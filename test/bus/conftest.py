"""Fixtures for the unit tests of the bus parts: a scripted peer on the far end of a real pty
(it records each instruction packet and answers with bytes the test gives) and a ``Transport``
opened on it. Packets are checked against dynamixel_sdk's CRC routine, not our own."""
from __future__ import annotations

from typing import Callable, Iterator

import pytest

from dynamixel_handler.bus.transport import Transport

from support.wire_peer import WirePeer, instruction, status, with_crc

__all__ = ["Answer", "Peer", "instruction", "line", "status", "with_crc"]

#: the peer: ``received`` holds every instruction packet, ``answer(packet)`` gives the bytes written
#: back (a list: one status packet per answering servo)
Peer = WirePeer
Answer = Callable[[bytes], list[bytes]]


@pytest.fixture
def line() -> Iterator[Callable[..., tuple[Peer, Transport]]]:
    """Factory: line(answer, **transport_kwargs) -> (peer, opened Transport). The adapter latency
    is 20 ms (the answering peer is a thread of the test process: on a loaded machine it can be a few
    milliseconds late) and retries are 1 ms apart unless given."""
    made: list[tuple[Peer, Transport]] = []

    def make(answer: Answer = lambda packet: [], **kwargs) -> tuple[Peer, Transport]:
        peer = Peer(answer)
        transport = Transport(peer.path, **{"baudrate": 1_000_000, "latency_timer_ms": 20.0,
                                            "retry_interval_ms": 1.0, **kwargs})
        transport.open()
        made.append((peer, transport))
        return peer, transport

    yield make
    for peer, transport in made:
        transport.close()
        peer.close()
