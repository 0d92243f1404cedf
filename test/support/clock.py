"""A clock advanced by hand, for parts that read ``time.monotonic()`` (patch the module's ``time``
with it) or take a clock callable (pass it as is)."""
from __future__ import annotations


class HandClock:
    """``t`` seconds until a test moves it (``clock.t += 1.0``)."""

    def __init__(self, t: float = 100.0) -> None:
        self.t = t

    def monotonic(self) -> float:
        return self.t

    def __call__(self) -> float:
        return self.t
