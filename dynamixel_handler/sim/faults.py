"""Faults the virtual bus puts on the replies on their way out: corrupted CRCs (at a rate),
truncated replies and noise bytes before the next reply."""
from __future__ import annotations

import collections
import random

Replies = list[tuple[float, bytes]]
"""Status packets to send, each after the answering servo's delay (seconds)."""


class ReplyFaults:
    """What is to go wrong with the next replies; ``counts`` gets ``crc_corrupted`` and
    ``truncated`` for each reply spoiled."""

    def __init__(self, rng: random.Random, counts: collections.Counter[str]) -> None:
        self._rng = rng
        self._counts = counts
        #: share of replies whose CRC is corrupted (0..1)
        self.crc_error_rate = 0.0
        self._garbage = bytearray()
        self._truncate = 0

    def inject_garbage(self, nbytes: int) -> None:
        """Noise bytes sent just before the next reply (never 0xFF, so never a header)."""
        self._garbage += bytes(self._rng.randrange(0, 0xFF) for _ in range(nbytes))

    def truncate_next(self, n: int = 1) -> None:
        """Cut the next ``n`` status packets short (only their first half goes out)."""
        self._truncate += n

    def apply(self, replies: Replies) -> Replies:
        """The replies as they go out: each maybe corrupted or cut, the noise before the first."""
        out = [(delay, self._spoil(reply)) for delay, reply in replies]
        if out and self._garbage:
            out[0] = (out[0][0], bytes(self._garbage) + out[0][1])
            self._garbage.clear()
        return out

    def _spoil(self, reply: bytes) -> bytes:
        if self.crc_error_rate > 0 and self._rng.random() < self.crc_error_rate:
            reply = reply[:-1] + bytes([reply[-1] ^ 0x5A])
            self._counts["crc_corrupted"] += 1
        if self._truncate > 0:
            self._truncate -= 1
            reply = reply[: max(1, len(reply) // 2)]
            self._counts["truncated"] += 1
        return reply
