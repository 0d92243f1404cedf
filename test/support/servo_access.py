"""A small in-process ``ServoAccess`` for unit tests of the command side: a real ``ServoTable``
of given models, queued requests taken at once, the core's typed calls recorded, no bus. Values the table lacks read as None."""
from __future__ import annotations

import logging
from typing import Any, Mapping

from dynamixel_handler.control_table import OPERATING_MODES, Model, model_by_number, protocol1_model_by_number
from dynamixel_handler.core.api import LoopFigures
from dynamixel_handler.core.request_types import DONE, Answer
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
        self.routes: dict[type, Any] = {}  # the command side's request types -> the part attached for them

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
    def attach(self, part: Any) -> None:
        for kind in part.TAKES:
            self.routes[kind] = part

    def submit(self, request: Any, what: str = "") -> None:
        """A queued request: taken at once by the part attached for its type."""
        self.routes[type(request)].handle(request)

    @property
    def core(self) -> FakeAccess:
        """The core's typed calls: goals kept, a mode set; every call but goals recorded."""
        return self

    def _did(self, name: str, *args: Any) -> Answer:
        self.calls.append((name, *args))
        return DONE

    def set_goals(self, writes: Mapping[str, Mapping[int, int]], what: str = "goals") -> Answer:
        self.goals.append({item: dict(values) for item, values in writes.items()})
        for item, values in writes.items():
            self.pending.put(item, values)
        return DONE

    def change_mode(self, dxl_id: int, mode: str, what: str = "mode") -> Answer:
        self.table.set_value("operating_mode", dxl_id, OPERATING_MODES[mode])
        return self._did("change_mode", dxl_id, mode)

    def defer_mode_change(self, dxl_id: int, why: Any, then: object, what: str = "") -> Answer:
        return self._did("defer_mode_change", dxl_id)

    def cancel_deferred(self, dxl_id: int) -> Answer:
        return self._did("cancel_deferred", dxl_id)

    def clear_error(self, dxl_id: int, keep_rotation: bool, what: str = "") -> Answer:
        return self._did("clear_error", dxl_id, keep_rotation)

    def torque_on(self, dxl_id: int, what: str = "") -> Answer:
        return self._did("torque_on", dxl_id)

    def torque_off(self, dxl_id: int) -> Answer:
        return self._did("torque_off", dxl_id)

    def write_item(self, dxl_id: int, item: str, pulses: int, what: str = "") -> Answer:
        return self._did("write_item", dxl_id, item, pulses)

    def write_eeprom(self, dxl_id: int, item: str, pulses: int) -> Answer:
        return self._did("write_eeprom", dxl_id, item, pulses)

    def write_eeprom_many(self, dxl_id: int, values: dict[str, int]) -> Answer:
        return self._did("write_eeprom_many", dxl_id, dict(values))

    def reboot(self, dxl_id: int, keep_turns: bool = False) -> Answer:
        return self._did("reboot", dxl_id, *(("keep_turns",) if keep_turns else ()))

    def add_servo(self, dxl_id: int) -> Answer:
        return self._did("add_servo", dxl_id)

    def remove_servo(self, dxl_id: int) -> Answer:
        return self._did("remove_servo", dxl_id)

    def want_handled(self, dxl_id: int, handled: bool) -> Answer:
        return self._did("want_handled", dxl_id, handled)

    def set_user_watchdog(self, dxl_id: int, pulses: int) -> Answer:
        return self._did("set_user_watchdog", dxl_id, pulses)

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


def attached(part: Any) -> Any:
    """``part`` (a Commander, Book, JointGoals...) attached to its handler's intake, as the node
    attaches the parts it builds: its queued requests are taken from now on."""
    part.h.attach(part)
    return part
