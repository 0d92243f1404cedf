"""Requests: goals (a tripped watchdog cleared first), a mode change and what it writes back, a
mode change asked for too soon, an error clear (on a fake bus, through the Handler front)."""
from __future__ import annotations

import logging

from dynamixel_handler.config import defaults, validate
from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.handler import Handler
from dynamixel_handler.core.request_types import Later, Outcome

from support.fake_bus import XM430, FakeBus

LOG = logging.getLogger("test_requests")


def started(**params) -> tuple[FakeBus, Handler]:
    bus = FakeBus({1: XM430, 2: XM430})
    for dxl_id in (1, 2):
        bus.set(dxl_id, "operating_mode", OPERATING_MODES["position"])
        bus.set(dxl_id, "max_position_limit", 4095)
    h = Handler(bus, validate({**defaults(), "init/servo_auto_search.max_id": 2, **params}), LOG)
    h.start()
    h.step()
    bus.calls.clear()
    return bus, h


def test_a_mode_change_goes_torque_off_mode_ram_back_torque_on_and_arms_the_watchdog_next_step():
    bus, h = started(mode_change_interval_sec=0.0)
    bus.set(1, "profile_velocity", 55)
    h.table.set_value("profile_velocity", 1, 55)
    assert h.core.change_mode(1, "velocity", "test").outcome is Outcome.DONE
    assert [w[1] for w in bus.item_writes()] == [
        "torque_enable", "operating_mode",                      # torque off (an EEPROM item), the mode
        "goal_pwm", "goal_current", "goal_velocity", "profile_velocity", "profile_acceleration",  # RAM back
        "goal_velocity", "torque_enable"]                       # torque back on safely: goal := 0 first
    assert ("write", "profile_velocity", (1, 55)) in bus.item_writes()
    assert h.watchdog.to_arm == {1}
    bus.calls.clear()
    h.step()
    assert ("sync_write", "bus_watchdog", {1: h.watchdog.watchdog_for(1)}) in bus.item_writes()


def test_a_mode_change_too_soon_waits_and_the_latest_request_is_made_when_its_time_comes():
    bus, h = started(mode_change_interval_sec=60.0)
    assert h.core.change_mode(1, "velocity", "first").outcome is Outcome.DONE
    later = h.core.change_mode(1, "pwm", "second")
    assert later.outcome is Outcome.LATER and later.later is Later.INTERVAL
    h.core.defer_mode_change(1, later.later, "the request again", "second")
    assert 1 in h.work.deferred and h.requests.mode_change_wait(1) > 59
    h.core.cancel_deferred(1)
    assert 1 not in h.work.deferred


def test_goals_to_a_servo_whose_watchdog_tripped_clear_it_before_they_are_written():
    bus, h = started()
    h.table.set_value("bus_watchdog", 2, -1)
    h.core.set_goals({"goal_position": {2: 100}})
    assert h.figures().watchdog_trips == 1
    h.steps.send_writes(h.steps.begin_step())
    items = [(w[1], w[2]) for w in bus.item_writes()]
    assert items[0] == ("bus_watchdog", (2, 0)) and items[-1] == ("goal_position", {2: 100})


def test_an_error_clear_reboots_only_a_servo_with_an_error_and_brings_its_torque_back():
    bus, h = started(clear_error_interval_sec=0.0)
    assert h.core.clear_error(1, False, "test") and not bus.of("reboot")  # no error: nothing
    bus.set(1, "hardware_error_status", 0x20)
    bus.set(1, "shutdown", 0x20)
    assert h.core.clear_error(1, False, "test")
    assert bus.of("reboot") == [("reboot", 1)] and bus.item_writes()[-1] == ("write", "torque_enable", (1, 1))
    bus.silent.add(2)
    failed = h.core.clear_error(2, False, "test")
    assert failed.outcome is Outcome.FAILED
    assert failed.failure == "test: ID 2 did not answer the hardware error read: not rebooted"


def test_a_servo_removed_by_any_door_is_forgotten_by_every_part_with_one_line():
    """A removal is an event of the table the parts observe: a remove_id request and a servo
    removed for its silence leave nothing of it waiting anywhere."""

    lines: list[str] = []
    bus, h = started(no_response_id_auto_remove_count=2)
    h.log = logging.getLogger("test_requests_removed")
    h.log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    h.log.setLevel(logging.INFO)
    for dxl_id in (1, 2):
        h.pending.put("goal_position", {dxl_id: 3000})
        h.core.set_user_watchdog(dxl_id, 5)
    assert h.watchdog.user == {1: 5, 2: 5}

    h.core.remove_servo(2)                      # a command's remove_id
    assert 2 not in h.table and 2 not in h.pending.peek("goal_position") and 2 not in h.watchdog.user
    assert lines.count("ID 2: removed from the handled servos") == 1

    bus.silent.add(1)                          # silent past no_response_id_auto_remove_count
    for _ in range(40):
        h.step()
        if 1 not in h.table:
            break
    assert 1 not in h.table and not h.pending.peek("goal_position") and not h.watchdog.user
    assert lines.count("ID 1: removed from the handled servos") == 1
