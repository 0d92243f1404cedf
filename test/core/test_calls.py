"""CoreCalls: the command side's typed calls in the loop thread, each reaching the part that does
it over the real parts on a fake bus (``support.parts``), and answering an ``Answer`` a caller can
act on; nothing of it is queued."""
from __future__ import annotations

import logging

from dynamixel_handler.core.calls import CoreCalls
from dynamixel_handler.core.request_types import Later, Outcome
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus
from support.parts import Parts, build, lines_of


def started(name: str, **changes) -> tuple[FakeBus, Parts, CoreCalls, list[str]]:
    bus = FakeBus({1: XM430, 2: XM430})
    log, lines = lines_of(f"test_calls.{name}", logging.INFO)
    parts = build(bus, Settings().but(scan__max_id=3, **changes), log)
    parts.startup.start()
    parts.steps.step()
    bus.calls.clear()
    lines.clear()
    return bus, parts, parts.core, lines


def test_goals_wait_for_the_next_write_and_ram_writes_go_out_at_once():
    bus, parts, core, _ = started("goals")
    assert core.set_goals({"goal_position": {1: 1000}}, "goal").outcome is Outcome.DONE
    assert bus.calls == [] and parts.pending.peek("goal_position") == {1: 1000}
    assert core.write_item(2, "led", 1) and bus.item_writes() == [("write", "led", (2, 1))]
    assert core.torque_off(1) and ("write", "torque_enable", (1, 0)) in bus.item_writes()


def test_a_failure_is_an_answer_with_the_reason_not_an_exception():
    bus, _, core, _ = started("failure")
    missing = core.write_eeprom(1, "no_such_item", 1)
    assert missing.outcome is Outcome.FAILED and missing.failure == "ID 1 (XM430-W350) has no no_such_item"
    bus.set(2, "torque_enable", 1)  # holding its load
    both = core.write_eeprom_many(2, {"temperature_limit": 70, "max_voltage_limit": 140})
    assert both.outcome is Outcome.DONE
    torque = [w[2] for w in bus.item_writes() if w[1] == "torque_enable"]
    assert torque == [(2, 0), (2, 1)]  # one torque-off window for both items
    assert bus.get(2, "temperature_limit") == 70 and bus.get(2, "max_voltage_limit") == 140
    bus.silent.add(3)
    added = core.add_servo(3)
    assert added.outcome is Outcome.FAILED and added.failure == "ID 3 not added"


def test_a_second_reboot_too_soon_is_refused_with_its_reason():
    bus, _, core, _ = started("reboot", loop__clear_error_interval_s=60.0)
    assert core.reboot(1) and bus.of("reboot") == [("reboot", 1)]
    again = core.reboot(1)
    assert again.outcome is Outcome.FAILED and again.failure.startswith("refused: the last one was")
    assert bus.of("reboot") == [("reboot", 1)]


def test_membership_and_the_user_watchdog_reach_their_parts():
    _, parts, core, _ = started("membership")
    core.set_user_watchdog(2, 5)
    assert parts.watchdog.user[2] == 5
    core.want_handled(2, False)
    assert 2 in parts.table  # applied once a loop, after the queued requests
    parts.steps.step()
    assert 2 not in parts.table and 2 not in parts.watchdog.user
    core.remove_servo(1)
    assert 1 not in parts.table


def test_a_deferred_request_is_kept_until_a_later_one_cancels_it():
    _, parts, core, _ = started("deferred", loop__mode_change_interval_s=60.0)
    assert core.change_mode(1, "velocity", "first")
    later = core.change_mode(1, "pwm", "second")
    assert later.outcome is Outcome.LATER and later.later is Later.INTERVAL
    core.defer_mode_change(1, later.later, "the command again", "second")
    assert parts.work.deferred[1][1:] == ("second", "the command again")
    core.cancel_deferred(1)
    assert 1 not in parts.work.deferred


def test_the_e_stop_gate_refuses_only_what_would_move_a_servo():
    bus, parts, core, lines = started("gate")
    parts.e_stop.engage("test")
    bus.calls.clear()
    assert core.torque_on(1).outcome is Outcome.REFUSED
    assert core.write_item(1, "torque_enable", 0)  # torque off by a RAM write moves nothing
    assert core.set_goals({"profile_velocity": {1: 10}}).outcome is Outcome.DONE
    assert core.set_goals({"goal_position": {1: 10}, "profile_velocity": {1: 10}}).outcome is Outcome.REFUSED
    assert "E-stop engaged (test): torque on refused" in lines


def test_a_reboot_that_keeps_turns_gives_a_multi_turn_servo_its_turns_back():
    bus, parts, core, lines = started("reboot_turns", loop__clear_error_interval_s=0.0)
    assert parts.io.write_item(1, "operating_mode", 4)  # extended position
    bus.set(1, "present_position", 3 * 4096 + 100)
    servo = bus.memory_line.servos[1]
    booted = servo.reboot

    def boot(now=None):  # as the firmware does: the count starts again within one turn of the offset
        booted(now)
        bus.set(1, "present_position", 100)
        bus.set(1, "torque_enable", 0)
    servo.reboot = boot
    assert core.reboot(1, keep_turns=True)
    assert bus.get(1, "homing_offset") == 3 * 4096
    assert any("ID 1: +3 whole turns lost at boot given back through its Homing Offset" in line for line in lines)
    bus.set(1, "present_position", 100)  # a reboot that does not keep them: nothing read before, nothing written
    bus.calls.clear()
    assert core.reboot(1) and bus.get(1, "homing_offset") == 3 * 4096
    assert [c for c in bus.calls if c[0] == "write" and c[2] == 20] == []  # Homing Offset (address 20) untouched
