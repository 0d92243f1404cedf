"""A small part that takes queued requests, for tests of the core without the command side: its
requests cross the queue as the command side's do (``Intake``) and are carried out in the loop
thread through the core's typed calls (``CoreCalls``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, assert_never


@dataclass(frozen=True)
class Led:
    """The servo's LED on (one RAM write)."""

    dxl_id: int
    what: str = "led"


@dataclass(frozen=True)
class Membership:
    """add_id (True) or remove_id (False), as the shortcut commands ask."""

    dxl_id: int
    handled: bool
    what: str = "add_id / remove_id"


class Asker:
    """Takes ``Led`` and ``Membership``; ``core``: the core's typed calls."""

    TAKES: ClassVar[tuple[type, ...]] = (Led, Membership)

    def __init__(self, core: Any) -> None:
        self.core = core

    def handle(self, request: Led | Membership) -> None:
        match request:
            case Led(dxl_id=dxl_id):
                self.core.write_item(dxl_id, "led", 1)
            case Membership(dxl_id=dxl_id, handled=handled):
                self.core.want_handled(dxl_id, handled)
            case _:
                assert_never(request)
