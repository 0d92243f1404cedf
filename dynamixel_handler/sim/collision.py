"""Two servos at one ID: their replies collide on the wire, as on hardware.

Every servo that hears a packet addressed to its ID answers it, so two servos sharing an ID both
start a status packet about their Return Delay Time after the instruction. The half-duplex line
then carries both at once. The model, simple and deterministic so tests can predict the bytes:

* the k-th servo at the ID (in the order they were added to the bus, k = 0, 1, ...) starts its
  reply at its own Return Delay Time plus ``k * skew_bytes`` byte-times (two servos never start
  on the same bit: their clocks and firmware loops differ; the default skew is 2 bytes);
* where replies overlap, the line carries the bitwise AND of their bytes: the UART's idle and
  stop level is 1 and a driver pulling the line to 0 wins (wired-AND), byte-aligned for
  simplicity;
* where one reply ends before the other starts (Return Delay Times far apart), the host gets two
  complete replies back to back, with the line idle between them.

So equal delays give one garbled packet (a CRC error, or a length that makes the host wait for
bytes that never come), delays a reply's length apart give two valid replies for one request.
Replies of different IDs (a broadcast ping's) are left as they are.
"""

from __future__ import annotations

from typing import Callable

from .faults import Replies

DEFAULT_SKEW_BYTES = 2


def status_id_2(reply: bytes) -> int | None:
    """The ID of a Protocol 2.0 status packet (byte 4)."""
    return reply[4] if len(reply) > 4 else None


def status_id_1(reply: bytes) -> int | None:
    """The ID of a Protocol 1.0 status packet (byte 2)."""
    return reply[2] if len(reply) > 2 else None


def overlap(replies: Replies, bps: int, id_of: Callable[[bytes], int | None],
            skew_bytes: int = DEFAULT_SKEW_BYTES) -> Replies:
    """The replies as the wire carries them: runs of consecutive replies from one ID merged as
    the module describes; ``bps`` converts the servos' delays to byte-times."""
    out: Replies = []
    k = 0
    while k < len(replies):
        end = k + 1
        while end < len(replies) and id_of(replies[end][1]) == id_of(replies[k][1]):
            end += 1
        out += replies[k:end] if end - k == 1 else _merge(replies[k:end], 10.0 / bps, skew_bytes)
        k = end
    return out


def _merge(group: Replies, byte_s: float, skew_bytes: int) -> Replies:
    """One ID's replies on the line: chunks of bytes, each after the idle time before it."""
    starts = [delay / byte_s + n * skew_bytes for n, (delay, _) in enumerate(group)]
    first = min(starts)
    positions = [int(round(s - first)) for s in starts]
    size = max(pos + len(reply) for pos, (_, reply) in zip(positions, group))
    line = bytearray(b"\xff" * size)
    driven = [False] * size
    for pos, (_, reply) in zip(positions, group):
        for i, byte in enumerate(reply):
            line[pos + i] &= byte
            driven[pos + i] = True
    chunks: Replies = []
    idle_from, i = 0, 0
    while i < size:
        if not driven[i]:
            i += 1
            continue
        j = i
        while j < size and driven[j]:
            j += 1
        gap = (first if not chunks else 0.0) * byte_s + (i - idle_from) * byte_s
        chunks.append((gap, bytes(line[i:j])))
        idle_from = i = j
    return chunks
