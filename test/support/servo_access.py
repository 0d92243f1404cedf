"""A small in-process ``ServoAccess`` for unit tests of the command side: a real ``ServoTable``
of given models, requests run at once and recorded, no bus. Values the table lacks read as None."""
from __future__ import annotations

import dataclasses
import logging
import re
from typing import Any, Callable, Mapping

from dynamixel_handler.control_table import OPERATING_MODES, Model, model_by_number, protocol1_model_by_number
from dynamixel_handler.core.api import LoopFigures
from dynamixel_handler.core.request_types import DONE, Answer, ChangeMode, SetGoals
from dynamixel_handler.core.state import recheck_loops
from dynamixel_handler.servo.table import PendingWrites, ServoTable
from dynamixel_handler.settings import Settings


class FakeAccess:
    """``ServoAccess`` over a table of ``servos`` (ID -> model number), each in ``modes`` (default
    position) and with the register values of ``values`` ({item: {ID: pulses}})."""

    def __init__(self, servos: Mapping[int, int], modes: Mapping[int, str] | None = None,
                 values: Mapping[str, Mapping[int, int]] | None = None) -> None:
        self.log = logging.getLogger("fake_access")
        self.settings = Settings()
        self.table = ServoTable()
        for dxl_id, number in sorted(servos.items()):
            self.table.add(dxl_id, _model(number))
        for dxl_id in servos:
            mode = (modes or {}).get(dxl_id, "position")
            self.table.set_value("operating_mode", dxl_id, self.table.model(dxl_id).mode_values.get(mode, OPERATING_MODES[mode]))
        for item, per_id in (values or {}).items():
            for dxl_id, pulses in per_id.items():
                self.table.set_value(item, dxl_id, pulses)
        self.goals: list[dict[str, dict[int, int]]] = []  # put_goals, in order
        self.pending = PendingWrites()  # what put_goals left for the next write
        self.calls: list[tuple[Any, ...]] = []  # every other request, in order: (snake_case type, fields but what)
        self.routes: dict[type, Callable[[Any], Any]] = {}  # the command side's request types

    # ------------------------------------------------------------ what is known
    def figures(self) -> LoopFigures:
        """A loop that has not run yet: no period measured, the default recheck interval."""
        return LoopFigures(loop_count=0, loop_period_s=0.0, recheck_loops=recheck_loops(self.settings.loop.rate_hz),
                           device_lost=False, device_lost_since=None, reconnects=0, watchdog_trips=0)

    @property
    def handled_ids(self) -> list[int]:
        return list(self.table.ids)

    def handles(self, dxl_id: int) -> bool:
        return dxl_id in self.table

    def model(self, dxl_id: int):
        return self.table.model(dxl_id)

    def mode(self, dxl_id: int) -> str | None:
        value = self.table.value("operating_mode", dxl_id)
        return self.table.model(dxl_id).mode_name(value) if value is not None else None

    def value(self, dxl_id: int, item: str) -> int | None:
        return self.table.value(item, dxl_id)

    # ------------------------------------------------------------ requests
    def register(self, kind: type, handler: Callable[[Any], Any]) -> None:
        self.routes[kind] = handler

    def submit(self, request: Any, what: str = "") -> None:
        """A queued request: run at once by the handler registered for it (or asked of the core)."""
        if type(request) in self.routes:
            self.routes[type(request)](request)
        else:
            self.ask(request)

    def ask(self, request: Any) -> Answer:
        """A core request: goals kept, a mode set; every request but goals recorded."""
        if isinstance(request, SetGoals):
            self.goals.append({item: dict(values) for item, values in request.writes.items()})
            for item, values in request.writes.items():
                self.pending.put(item, values)
            return DONE
        name = re.sub(r"(?<!^)(?=[A-Z])", "_", type(request).__name__).lower()
        self.calls.append((name, *[getattr(request, f.name) for f in dataclasses.fields(request)
                                   if f.name not in ("what", "why", "then")]))
        if isinstance(request, ChangeMode):
            self.table.set_value("operating_mode", request.dxl_id, OPERATING_MODES[request.mode])
        return DONE

    def read_item(self, dxl_id: int, item: str) -> int | None:
        return self.table.value(item, dxl_id)


def _model(number: int) -> Model:
    """A Protocol 2.0 model, or a Protocol 1.0 one where the number is none of the 2.0 ones."""
    try:
        return model_by_number(number)
    except KeyError:
        return protocol1_model_by_number(number)


def warnings_of(access: FakeAccess) -> list[str]:
    """The warning lines the commander of ``access`` logs from now on."""
    lines: list[str] = []
    access.log = logging.getLogger(f"fake_access_{id(access)}")
    access.log.propagate = False
    access.log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    return lines
