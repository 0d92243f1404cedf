"""``Result``: what a bus call returned, with why it failed, as one value (no shared "last
failure" to read afterwards, which another thread's call may have changed meanwhile)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T", covariant=True)


@dataclass(frozen=True, slots=True)
class Result(Generic[T]):
    """``value``: what the call gives (data, a model number, True) or its failure value (None,
    False); ``failure``: why it failed, "" when it worked. True in a condition when it worked."""

    value: T
    failure: str = ""

    @property
    def ok(self) -> bool:
        return not self.failure

    def __bool__(self) -> bool:
        return not self.failure
