"""Reboots on its own over the real parts it calls (``support.parts``, a fake bus): a servo that
stays silent after its reboot is waited for at most ``REBOOT_WAIT_S`` and named in one warning, and a
reboot on a closed port waits for nothing and puts nothing back. (test_recovery.py asks for the
reboot that answers, what it puts back and the limit of one per clear_error_interval_sec.)"""
from __future__ import annotations

import logging

from dynamixel_handler.bus import Failure
from dynamixel_handler.core import reboots
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus
from support.parts import Parts, build, lines_of


def handled(name: str) -> tuple[FakeBus, Parts, list[str]]:
    bus = FakeBus({1: XM430})
    log, lines = lines_of(f"test_reboots.{name}", logging.INFO)
    parts = build(bus, Settings(), log)
    parts.table.add(1, bus.models[1])
    parts.table.set_value("profile_velocity", 1, 40)
    return bus, parts, lines


def test_a_servo_silent_after_its_reboot_is_waited_for_a_while_and_named_in_one_warning(monkeypatch):
    monkeypatch.setattr(reboots, "REBOOT_WAIT_S", 0.1)  # the wait itself, shortened for the test
    bus, parts, lines = handled("silent")
    bus.silent.add(1)
    rebooted = parts.reboots.reboot(1)
    assert not rebooted and rebooted.failure is Failure.NO_REPLY
    assert len(bus.of("ping")) >= 2  # asked again until the deadline
    assert [line for line in lines if "after reboot" in line] == ["ID 1: no answer 0.1s after reboot"]


def test_a_reboot_on_a_closed_port_waits_for_nothing_and_puts_nothing_back():
    bus, parts, lines = handled("closed")
    bus.is_open = False
    rebooted = parts.reboots.reboot(1)
    assert not rebooted
    assert rebooted.failure is Failure.DEVICE_LOST
    assert bus.calls == []  # nothing reaches the line: no reboot, no ping, no profile written back, no watchdog armed
    assert not [line for line in lines if "after reboot" in line]
