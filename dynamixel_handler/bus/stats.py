"""Counters of a bus (``BusStats``)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass
class BusStats:
    """Counters since open (or the last ``reset``); cheap to copy for a per-period log line.

    ``transactions`` counts calls that used the wire (a sync read of 10 servos is one),
    ``packets_sent`` every instruction packet including retries.
    """

    transactions: int = 0
    successes: int = 0          # at least one addressed servo answered (or a no-reply write was sent)
    full_successes: int = 0     # every addressed servo answered
    packets_sent: int = 0
    retries: int = 0
    timeouts: int = 0           # waits that ended with an expected reply missing
    crc_errors: int = 0
    servo_errors: int = 0       # status packets whose error number says the servo refused
    discarded_bytes: int = 0    # stale replies and noise dropped from the input
    bytes_tx: int = 0
    bytes_rx: int = 0
    time_s: float = 0.0         # wall time spent inside bus calls
    disconnects: int = 0

    @property
    def success_rate(self) -> float:
        return self.successes / self.transactions if self.transactions else 1.0

    @property
    def full_success_rate(self) -> float:
        return self.full_successes / self.transactions if self.transactions else 1.0

    def copy(self) -> "BusStats":
        return dataclasses.replace(self)

    def delta(self, earlier: "BusStats") -> "BusStats":
        """Counters accumulated since the snapshot ``earlier`` (for a per-period log line)."""
        return BusStats(**{f.name: getattr(self, f.name) - getattr(earlier, f.name)
                           for f in dataclasses.fields(self)})

    def reset(self) -> None:
        for item in dataclasses.fields(self):
            setattr(self, item.name, item.default)
