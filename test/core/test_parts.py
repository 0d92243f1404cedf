"""core.parts: the parts of one bus built and wired in one place (what the Handler and the unit
tests both build): every core request type taken by a part, a removal forgotten by every part that
keeps something per servo, new settings and a new log reaching each part."""
from __future__ import annotations

import dataclasses
import logging

from dynamixel_handler.core import request_types
from dynamixel_handler.core.parts import build_parts, part_settings
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus

LOG = logging.getLogger("test_parts")


def _started(settings: Settings | None = None):
    bus = FakeBus({1: XM430, 2: XM430})
    parts = build_parts(bus, settings or Settings().but(scan__max_id=2), LOG, lambda: False)
    parts.startup.start()
    return bus, parts


def test_every_queued_request_type_of_the_core_is_taken_by_a_part_and_the_typed_calls_reach_theirs():
    _, parts = _started()
    kinds = {k for k in vars(request_types).values()
             if isinstance(k, type) and dataclasses.is_dataclass(k) and k.__module__ == request_types.__name__
             and k.__name__ not in ("Answer",)}
    assert parts.intake.routes() == {kind: "EStop" for kind in kinds}
    assert parts.core.torque_off(1)  # done by ServoIO
    assert parts.core.write_eeprom(1, "no_such_item", 1).failure == "ID 1 (XM430-W350) has no no_such_item"


def test_a_removed_servo_is_forgotten_by_the_parts_that_keep_something_of_it():
    bus, parts = _started()
    parts.pending.put("goal_position", {1: 100, 2: 200})
    parts.core.set_user_watchdog(2, 5)
    parts.core.remove_servo(2)
    assert 2 not in parts.table and parts.pending.peek("goal_position") == {1: 100}
    assert 2 not in parts.watchdog.user
    bus.calls.clear()
    parts.steps.step()
    goals = [v for kind, item, v in bus.item_writes() if kind == "sync_write" and item == "goal_position"]
    assert goals == [{1: 100}], bus.calls                             # the goal of ID 1 only
    assert all(2 not in ids for _, _, _, ids, _ in bus.of("sync_read")), bus.calls  # ID 2 no longer read


def test_new_settings_and_a_new_log_reach_every_part():
    _, parts = _started()
    slow = Settings().but(loop__rate_hz=5, scan__max_id=2)
    parts.apply(slow)
    assert parts.watchdog.settings == part_settings(slow).watchdog and parts.steps.settings == part_settings(slow).step
    other = logging.getLogger("test_parts_other")
    parts.set_log(other)
    assert all(getattr(parts, name).log is other for name in ("io", "group", "reads", "writes", "watchdog", "work",
                                                              "intake", "recovery", "startup", "requests", "steps",
                                                              "ending"))
