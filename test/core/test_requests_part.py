"""Requests, built on its own over the real parts it calls (``support.parts``, a fake bus): what a
mode change writes and answers, a mode change asked for too soon or while the node stops, goals
to a servo whose bus watchdog tripped, and an error clear: what it reboots, what it refuses and
why, and the turns it keeps. (test_requests.py asks the same through the Handler front.)"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import pytest

from dynamixel_handler.bus.ops import Reboot
from dynamixel_handler.bus.result import Result
from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.request_types import Later, Outcome
from dynamixel_handler.core.requests import MODE_ATTEMPTS, MODE_RESET_ITEMS, MODE_RETRY_S, Requests
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus
from support.parts import Parts, build, lines_of


@dataclass(frozen=True)
class Again:
    """A command's request run again when its mode change may be made (``then``)."""

    dxl_id: int
    mode: str
    what: str = "again"


def started(name: str, bus: FakeBus | None = None, **changes) -> tuple[FakeBus, Parts, Requests, list[str]]:
    bus = bus or FakeBus({1: XM430, 2: XM430})
    for dxl_id in bus.models:
        bus.set(dxl_id, "operating_mode", OPERATING_MODES["position"])
        bus.set(dxl_id, "max_position_limit", 4095)
    log, lines = lines_of(f"test_requests_part.{name}", logging.INFO)
    parts = build(bus, Settings().but(scan__max_id=2, **changes), log)
    parts.startup.start()
    parts.steps.step()
    bus.calls.clear()
    lines.clear()
    return bus, parts, parts.requests, lines


def test_a_mode_change_writes_torque_off_the_mode_the_ram_back_and_torque_on_and_says_so():
    bus, parts, requests, lines = started("mode", loop__mode_change_interval_s=0.0)
    bus.set(1, "profile_velocity", 55)
    parts.table.set_value("profile_velocity", 1, 55)
    assert requests.change_mode(1, "velocity", "test").outcome is Outcome.DONE
    assert [w[1] for w in bus.item_writes()] == ["torque_enable", "operating_mode", *MODE_RESET_ITEMS,
                                                 "goal_velocity", "torque_enable"]
    assert ("write", "operating_mode", (1, OPERATING_MODES["velocity"])) in bus.item_writes()
    assert ("write", "profile_velocity", (1, 55)) in bus.item_writes()  # what the firmware resets, written back
    assert lines == ["ID 1: operating mode -> velocity"]
    assert parts.watchdog.to_arm == {1}  # the velocity mode needs a bus watchdog: armed at the next step


def test_a_mode_change_leaves_out_the_old_modes_own_goal():
    bus, parts, requests, _ = started("own goal", loop__mode_change_interval_s=0.0)
    assert requests.change_mode(1, "velocity", "test")
    bus.calls.clear()
    assert requests.change_mode(1, "position", "test")
    written = [w[1] for w in bus.item_writes()]
    assert "goal_velocity" not in written[:-2]  # a velocity goal would mean something else in position mode
    assert written[:2] == ["torque_enable", "operating_mode"]


def test_a_mode_change_the_servo_does_not_answer_is_tried_again_then_fails_with_the_reason():
    bus, parts, requests, lines = started("silent", loop__mode_change_interval_s=60.0)
    bus.silent.add(2)
    for attempt in range(1, MODE_ATTEMPTS):  # answered LATER: the caller defers it MODE_RETRY_S
        again = requests.change_mode(2, "velocity", "x/velocity_control")
        assert again.outcome is Outcome.LATER and again.later is Later.RETRY, attempt
        assert requests.mode_change_wait(2) == 0.0  # a change not made does not hold the next one back
    retries = [line for line in lines if "tried again in" in line]
    assert len(retries) == 1  # one line a second
    assert retries[0] == (f"x/velocity_control: ID 2 mode change to 'velocity' failed (write ID 2: no reply within 4.0 ms): tried again in "
                          f"{MODE_RETRY_S:g}s with its goals (attempt 2 of {MODE_ATTEMPTS})")
    requests.defer_mode_change(2, Later.RETRY, Again(2, "velocity", "x"), "x")
    assert parts.work.deferred[2][0] == pytest.approx(time.monotonic() + MODE_RETRY_S, abs=0.05)
    failed = requests.change_mode(2, "velocity", "x/velocity_control")
    assert failed.outcome is Outcome.FAILED
    assert failed.failure == (f"x/velocity_control: ID 2 mode change to 'velocity' failed after {MODE_ATTEMPTS} "
                              "attempt(s): write ID 2: no reply within 4.0 ms; the goals that came with it are not written")
    assert not any("operating mode ->" in line for line in lines)  # no line that it changed


def test_a_mode_change_too_soon_answers_later_and_waits_for_its_time_with_one_line():
    bus, parts, requests, lines = started("too soon", loop__mode_change_interval_s=60.0)
    assert requests.change_mode(1, "velocity", "first")
    bus.calls.clear()
    later = requests.change_mode(1, "pwm", "second")
    assert later.outcome is Outcome.LATER and later.later is Later.INTERVAL and bus.calls == []
    for what in ("second", "third"):
        requests.defer_mode_change(1, Later.INTERVAL, Again(1, "pwm", what), what)
    waits = [line for line in lines if "mode_change_interval_sec" in line]
    assert len(waits) == 1 and waits[0].startswith("second: the last mode change was less than "
                                                   "mode_change_interval_sec=60s ago: applied in")
    assert parts.work.deferred[1][2] == Again(1, "pwm", "third")  # the latest request is the one made
    assert 59.0 < requests.mode_change_wait(1) <= 60.0
    parts.core.cancel_deferred(1)  # a later command for the servo wins
    assert 1 not in parts.work.deferred


def test_a_mode_change_while_the_node_stops_is_dropped_and_nothing_is_written():
    bus, parts, requests, _ = started("stopping", loop__mode_change_interval_s=0.0)
    parts.stopping[0] = True
    stopping = requests.change_mode(1, "velocity", "test")
    assert stopping.outcome is Outcome.LATER and stopping.later is Later.STOPPING
    requests.defer_mode_change(1, Later.STOPPING, Again(1, "velocity"), "test")
    assert bus.calls == [] and parts.pacing.dropped_mode_changes == {1} and not parts.work.deferred


def test_goals_are_written_with_the_next_sync_write_after_a_tripped_watchdog_is_cleared():
    bus, parts, requests, _ = started("goals")
    parts.table.set_value("bus_watchdog", 2, -1)  # tripped: the servo refuses goals until cleared
    requests.put_goals({"goal_position": {2: 100}})
    assert bus.item_writes() == [("write", "bus_watchdog", (2, 0))] and parts.watchdog.trips == 1
    parts.writes.send()
    assert bus.item_writes()[-1] == ("sync_write", "goal_position", {2: 100})
    bus.calls.clear()
    requests.put_goals({"goal_position": {1: 200}})  # nothing tripped: no watchdog write
    parts.writes.send()
    assert bus.item_writes() == [("sync_write", "goal_position", {1: 200})]


def test_an_error_clear_reboots_only_a_servo_with_an_error_and_brings_its_torque_back():
    bus, _, requests, lines = started("clear", loop__clear_error_interval_s=0.0)
    assert requests.clear_error(1, False, "CE") and not bus.of("reboot")
    bus.set(1, "hardware_error_status", 0x20)
    bus.set(1, "shutdown", 0x20)     # the error switched torque off: it comes back on
    bus.set(1, "torque_enable", 0)
    assert requests.clear_error(1, False, "CE").outcome is Outcome.DONE
    assert bus.of("reboot") == [("reboot", 1)]
    assert bus.item_writes()[-1] == ("write", "torque_enable", (1, 1))
    assert lines[-1] == "ID 1: hardware error cleared (turns reset)"


def test_an_error_clear_too_soon_is_refused_and_one_without_an_answer_fails_with_the_reason():
    bus, _, requests, _ = started("refused", loop__clear_error_interval_s=60.0)
    bus.set(1, "hardware_error_status", 0x20)
    assert requests.clear_error(1, False, "CE")
    bus.set(1, "hardware_error_status", 0x20)
    refused = requests.clear_error(1, False, "CE")
    assert refused.outcome is Outcome.REFUSED and bus.of("reboot") == [("reboot", 1)]
    assert refused.failure.startswith("CE: ID 1 error clear refused: the last one was")
    assert refused.failure.endswith("ago (clear_error_interval_sec=60)")
    bus.silent.add(2)
    failed = requests.clear_error(2, False, "CE")
    assert failed.outcome is Outcome.FAILED
    assert failed.failure == "CE: ID 2 did not answer the hardware error read: not rebooted"


class TurnsLostOnReboot(FakeBus):
    """A reboot brings the present position back within one turn, as the firmware does."""

    def execute(self, op: Any) -> Result[Any]:
        if isinstance(op, Reboot):
            self.set(op.dxl_id, "present_position", self.get(op.dxl_id, "present_position") % 4096)
        return super().execute(op)


def test_an_error_clear_that_keeps_the_rotation_moves_the_lost_turns_into_the_homing_offset():
    bus = TurnsLostOnReboot({1: XM430, 2: XM430})
    bus, _, requests, lines = started("turns", bus, loop__clear_error_interval_s=0.0)
    bus.set(1, "present_position", 2 * 4096 + 100)
    bus.set(1, "homing_offset", 10)
    bus.set(1, "hardware_error_status", 0x04)
    assert requests.clear_error(1, True, "CE")
    assert ("write", "homing_offset", (1, 10 + 2 * 4096)) in bus.item_writes()
    assert lines[-1] == "ID 1: hardware error cleared (turns kept)"
