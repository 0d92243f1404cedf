"""``core.api``: the one narrow interface the command side is written against. Any object with its
doors is a ``ServoAccess`` (and one without them is not); a Commander over the core's parts reached
through these doors alone (no Handler) moves a servo, switching its mode first; ``LoopFigures`` is a
value the loop does not change once handed out."""
from __future__ import annotations

import dataclasses
import logging

import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.api import LoopFigures, ServoAccess
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus
from support.parts import Parts, build, lines_of
from support.servo_access import FakeAccess


class PartsAccess:
    """``ServoAccess`` over the parts: each door one call of the part whose it is."""

    def __init__(self, parts: Parts, settings: Settings) -> None:
        self.parts, self.settings, self.log = parts, settings, parts.log
        self.table, self.pending = parts.table, parts.pending

    @property
    def handled_ids(self) -> list[int]:
        return list(self.table.ids)

    def figures(self) -> LoopFigures:
        p = self.parts
        return LoopFigures(p.steps.loop_count, p.watchdog.loop_period_s, p.steps.settings.recheck_loops,
                           p.recovery.device_lost, p.recovery.device_lost_since, p.recovery.reconnects, p.watchdog.trips)

    def handles(self, dxl_id):
        return dxl_id in self.table

    def model(self, dxl_id):
        return self.table.model(dxl_id)

    def mode(self, dxl_id):
        return self.parts.io.mode(dxl_id)

    def value(self, dxl_id, item):
        return self.parts.io.value(dxl_id, item)

    def submit(self, request, what=""):
        self.parts.intake.submit(request, what)

    @property
    def core(self):
        return self.parts.core

    def read_item(self, dxl_id, item):
        return self.parts.io.read_item(dxl_id, item)


def access(name: str) -> tuple[FakeBus, PartsAccess, list[str]]:
    bus = FakeBus({1: XM430, 2: XM430})
    for dxl_id in (1, 2):
        bus.set(dxl_id, "operating_mode", OPERATING_MODES["position"])
        bus.set(dxl_id, "velocity_limit", 200)
    log, lines = lines_of(f"test_servo_access.{name}", logging.INFO)
    settings = Settings().but(scan__max_id=2, loop__mode_change_interval_s=0.0)
    parts = build(bus, settings, log)
    parts.startup.start()
    parts.steps.step()
    bus.calls.clear()
    lines.clear()
    return bus, PartsAccess(parts, settings), lines


def test_an_object_with_every_door_is_a_servo_access_and_one_without_them_is_not():
    _, doors, _ = access("doors")
    assert isinstance(doors, ServoAccess) and isinstance(FakeAccess({1: XM430}), ServoAccess)
    assert not isinstance(object(), ServoAccess)
    half = type("Half", (), {"submit": lambda self, request, what="": None, "log": doors.log})()
    assert not isinstance(half, ServoAccess)


def test_a_commander_over_the_doors_alone_switches_the_mode_and_writes_the_goal_at_the_next_step():
    bus, doors, lines = access("commander")
    commander = Commander(doors)
    doors.parts.intake.attach(commander)  # as the node does once it built the Commander
    commander.control("X", "velocity_control", [1, 7], {"velocity_deg_s": [10.0, 10.0]})
    assert bus.calls == []  # queued for the loop thread: nothing on the bus yet
    doors.parts.steps.step()
    assert ("write", "operating_mode", (1, OPERATING_MODES["velocity"])) in bus.item_writes()
    pulses = round(10.0 / doors.model(1).velocity_deg_s_per_pulse)
    assert ("sync_write", "goal_velocity", {1: pulses}) in bus.item_writes()
    assert "x/velocity_control: ID 7 is not handled: ignored" in lines
    assert doors.figures().loop_count == 2


def test_loop_figures_are_a_value_the_loop_does_not_change_once_handed_out():
    _, doors, _ = access("figures")
    held = doors.figures()
    doors.parts.steps.step()
    assert held.loop_count == 1 and doors.figures().loop_count == 2
    with pytest.raises(dataclasses.FrozenInstanceError):
        held.loop_count = 5  # type: ignore[misc]
