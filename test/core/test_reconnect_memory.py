"""A reconnect puts back what the servo had (reconnect_memory, wired into Recovery by build_parts):
its profiles and mode rather than the start values, a goal of a velocity mode not resumed but said,
EEPROM items that differ from before named; the servos block's items keep the block's values."""
from __future__ import annotations

import logging

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.reconnect_memory import Remembered, remember
from dynamixel_handler.core.state import StepReport
from dynamixel_handler.servo.settings import ServoSetting
from dynamixel_handler.settings import Settings

from support.fake_bus import XM430, FakeBus
from support.parts import build, lines_of


def gone_and_back(bus: FakeBus, parts, while_gone=lambda: None) -> None:
    """The device vanishes for a while (``while_gone`` happens to the servos meanwhile) and comes back."""
    parts.recovery.watch_device()  # the device open at start-up
    bus.is_open, bus.can_reopen = False, False
    parts.recovery.reconnect(StepReport(loop=0))
    while_gone()
    bus.can_reopen = True
    parts.recovery._next_reconnect = 0.0
    parts.recovery.reconnect(StepReport(loop=1))
    assert not parts.recovery.device_lost


def started(entries=(), name="test_reconnect_memory"):
    bus = FakeBus({1: XM430})
    bus.set(1, "operating_mode", OPERATING_MODES["velocity"])
    bus.set(1, "velocity_limit", 200)
    log, lines = lines_of(name, logging.INFO)
    parts = build(bus, Settings(servos=tuple(entries)), log)
    parts.startup.start()
    parts.io.write_item(1, "profile_velocity", 15)  # what the owner set (20 deg/s)
    parts.io.write_item(1, "goal_velocity", 50)
    parts.io.read_item(1, "velocity_limit")  # as the limit group reads it
    return bus, parts, lines


def test_what_is_known_when_the_device_goes_is_remembered():
    bus, parts, _ = started()
    got = remember(parts.table, 1)
    assert isinstance(got, Remembered) and got.mode == "velocity" and got.goal == ("goal_velocity", 50)
    assert got.profiles["profile_velocity"] == 15 and got.eeprom["velocity_limit"] == bus.get(1, "velocity_limit")


def test_a_reconnect_puts_back_profiles_and_mode_says_the_goal_and_names_eeprom_that_differs():
    bus, parts, lines = started()
    limit = bus.get(1, "velocity_limit")

    def replaced() -> None:  # another servo at its ID, factory values: position mode, other limit, RAM at defaults
        bus.set(1, "operating_mode", OPERATING_MODES["position"])
        bus.set(1, "velocity_limit", limit - 10)
        bus.set(1, "profile_velocity", 0)
    gone_and_back(bus, parts, replaced)
    assert bus.get(1, "profile_velocity") == 15  # not the 1000 deg/s start value
    assert bus.get(1, "operating_mode") == OPERATING_MODES["velocity"] and bus.get(1, "goal_velocity") == 0
    text = "\n".join(lines)
    assert "ID 1 (XM430-W350): EEPROM differs from before the device went (replaced while unplugged, or changed by " \
           f"another tool?): operating_mode 1 -> 3, velocity_limit {limit} -> {limit - 10}" in text
    assert "ID 1: mode velocity as before the device went" in text
    assert "ID 1: as before the device went: profile_acceleration " in text and "profile_velocity 15 (not the start" in text
    assert "ID 1: goal_velocity " in text and "not resumed after the reconnect" in text


def test_the_servos_block_wins_over_what_the_servo_had():
    entry = ServoSetting(1, {"mode": "position", "profile_vel_deg_s": 60.0})
    bus, parts, lines = started((entry,))
    parts.io.write_item(1, "profile_velocity", 15)
    gone_and_back(bus, parts)
    assert bus.get(1, "profile_velocity") == round(60.0 / (0.229 * 6))
    assert bus.get(1, "operating_mode") == OPERATING_MODES["position"]
    assert not any("mode velocity as before" in x or "profile_velocity 15" in x for x in lines)


def test_a_servo_booted_while_silent_is_told_from_one_that_kept_its_power():
    from dynamixel_handler.core.reconnect_memory import booted
    bus, parts, _ = started()
    before = Remembered(mode="velocity", profiles={"profile_velocity": 15}, torque=1)
    bus.set(1, "torque_enable", 1)
    assert not booted(parts.io, 1, before)               # torque on, its profile as written: no boot
    bus.set(1, "torque_enable", 0)
    assert booted(parts.io, 1, before)                   # torque dropped
    bus.set(1, "hardware_error_status", 0x20)
    assert not booted(parts.io, 1, before)               # torque dropped by an overload shutdown: no boot
    bus.set(1, "hardware_error_status", 0)
    bus.set(1, "profile_velocity", 0)
    assert booted(parts.io, 1, Remembered(mode="velocity", profiles={"profile_velocity": 15}, torque=0))  # RAM reset
    assert not booted(parts.io, 1, Remembered(mode="velocity", profiles={"profile_velocity": 0}, torque=0))
    bus.silent = {1}
    assert booted(parts.io, 1, before) is None           # no answer: not known (asked again later)
