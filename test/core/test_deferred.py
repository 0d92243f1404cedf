"""Deferred: EEPROM writes spared and coalesced, per-servo requests due later (the queue of
requests is the Intake's: test_intake.py)."""
from __future__ import annotations

import logging
from dataclasses import dataclass

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core import deferred as deferred_module
from dynamixel_handler.core.deferred import EEPROM_WRITE_INTERVAL_S, Deferred
from dynamixel_handler.core.servo_io import ServoIO

from support.clock import HandClock
from support.fake_bus import XM430, FakeBus, table_of


@dataclass(frozen=True)
class Again:
    """A request run again when due (a command's, after its mode change waited)."""

    dxl_id: int
    mode: str

def work(monkeypatch):
    clock = HandClock(1000.0)
    monkeypatch.setattr(deferred_module, "time", clock)
    bus = FakeBus({1: XM430, 2: XM430})
    table = table_of(bus)
    lines: list[str] = []
    log = logging.getLogger(f"test_deferred_{id(bus)}")
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    return bus, table, Deferred(table, log, ServoIO(bus, table, log)), clock, lines


def test_an_eeprom_value_the_servo_has_is_not_written_and_one_asked_again_too_soon_is_written_once_later(monkeypatch):
    bus, _, part, clock, _ = work(monkeypatch)
    bus.set(1, "return_delay_time", 0)
    assert part.write_eeprom(1, "return_delay_time", 0)
    assert bus.item_writes() == []     # already so: spared
    assert part.write_eeprom(1, "return_delay_time", 5)
    assert part.write_eeprom(1, "return_delay_time", 6)
    assert part.write_eeprom(1, "return_delay_time", 7)
    assert [w for w in bus.item_writes() if w[1] == "return_delay_time"] == [("write", "return_delay_time", (1, 5))]
    assert part.waiting
    part.run_deferred()                # not due yet
    clock.t += EEPROM_WRITE_INTERVAL_S
    part.run_deferred()                # the latest value asked for, once
    assert [w for w in bus.item_writes() if w[1] == "return_delay_time"] == [
        ("write", "return_delay_time", (1, 5)), ("write", "return_delay_time", (1, 7))]
    assert not part.waiting


def test_an_eeprom_write_switches_torque_off_and_back_on_without_a_jump(monkeypatch):
    bus, table, part, _, _ = work(monkeypatch)
    bus.set(1, "torque_enable", 1)
    bus.set(1, "operating_mode", OPERATING_MODES["velocity"])
    bus.set(1, "goal_velocity", 100)
    assert part.write_eeprom(1, "velocity_limit", 200)
    assert [w[1:] for w in bus.item_writes()] == [("torque_enable", (1, 0)), ("velocity_limit", (1, 200)),
                                                  ("goal_velocity", (1, 0)), ("torque_enable", (1, 1))]


def test_work_due_later_runs_when_due_and_only_for_a_servo_still_handled(monkeypatch):
    _, table, part, clock, _ = work(monkeypatch)
    part.defer(1, clock.t + 0.5, "mode change", Again(1, "velocity"))
    part.defer(2, clock.t, "mode change", Again(2, "velocity"))
    table.remove(2)
    assert part.run_deferred() == [] and list(part.deferred) == [1]
    clock.t += 0.5
    assert part.run_deferred() == [("mode change", Again(1, "velocity"))] and not part.waiting
    part.defer(1, clock.t, "mode change", Again(1, "pwm"))
    part.forget(1)
    assert not part.waiting
