"""Whole turns lost at a boot given back (``core/turns.py``) over the fake bus: the Homing Offset
takes them, so the position reads as before; a servo that did not boot (torque on, or beyond one
turn of its offset), one that lost less than half a turn, or one whose offset would leave its range
is left alone with the reason."""
from __future__ import annotations

import logging

from dynamixel_handler.core.deferred import Deferred
from dynamixel_handler.core.servo_io import ServoIO
from dynamixel_handler.core.turns import give_back_turns, lost_turns

from support.fake_bus import XM430, FakeBus, table_of


def parts(**values):
    bus = FakeBus({1: XM430})
    for item, value in values.items():
        bus.set(1, item, value)
    table = table_of(bus)
    log = logging.getLogger(f"test_turns_{id(bus)}")
    io = ServoIO(bus, table, log)
    return bus, io, Deferred(table, log, io)


def homing_writes(bus):
    return [w for w in bus.item_writes() if w[1] == "homing_offset"]


def test_the_nearest_whole_number_of_turns_is_taken():
    model = table_of(FakeBus({1: XM430})).model(1)
    assert lost_turns(model, 3 * 4096 + 100, 100) == 3
    assert lost_turns(model, -2 * 4096 + 30, 10) == -2
    assert lost_turns(model, 1900, 100) == 0           # less than half a turn: moved, not lost
    assert lost_turns(model, 4096 + 2100, 0) == 2      # more than half a turn beyond one: the nearest


def test_a_booted_servo_gets_its_turns_back_through_its_homing_offset():
    bus, io, eeprom = parts(present_position=100, homing_offset=0, torque_enable=0)
    line = give_back_turns(io, eeprom, 1, 3 * 4096 + 100, booted=False)
    assert homing_writes(bus) == [("write", "homing_offset", (1, 3 * 4096))]
    assert "+3 whole turns lost at boot given back through its Homing Offset (0 -> 12288)" in line


def test_a_servo_that_did_not_boot_keeps_its_position():
    bus, io, eeprom = parts(present_position=100, homing_offset=0, torque_enable=1)  # torque still on
    assert give_back_turns(io, eeprom, 1, 3 * 4096 + 100, booted=False) == ""
    bus, io, eeprom = parts(present_position=2 * 4096, homing_offset=0, torque_enable=0)  # beyond a turn of 0
    assert give_back_turns(io, eeprom, 1, 5 * 4096, booted=False) == ""
    assert homing_writes(bus) == []


def test_after_a_reboot_torque_is_not_looked_at_and_nothing_lost_is_nothing_written():
    bus, io, eeprom = parts(present_position=100, homing_offset=4096, torque_enable=1)
    assert "+1 whole turns" in give_back_turns(io, eeprom, 1, 4096 + 100)  # booted: the caller knows
    bus, io, eeprom = parts(present_position=150, homing_offset=0, torque_enable=0)
    assert give_back_turns(io, eeprom, 1, 100) == "" and homing_writes(bus) == []


def test_turns_beyond_the_homing_offset_s_range_are_not_written_and_said():
    bus, io, eeprom = parts(present_position=0, homing_offset=0, torque_enable=0)
    line = give_back_turns(io, eeprom, 1, 300 * 4096, booted=False)
    assert homing_writes(bus) == [] and "+300 turns lost at boot not given back" in line and "beyond its range" in line


def test_a_servo_that_does_not_answer_is_said_and_nothing_is_written():
    bus, io, eeprom = parts(present_position=100, homing_offset=0, torque_enable=0)
    bus.silent = {1}
    line = give_back_turns(io, eeprom, 1, 3 * 4096 + 100, booted=False)
    assert line == "ID 1: whole turns lost at boot not looked for: its position or Homing Offset did not answer"
    assert homing_writes(bus) == []


def test_a_give_back_held_back_by_a_recent_write_of_the_offset_says_so_and_waits_to_be_written():
    bus, io, eeprom = parts(present_position=100, homing_offset=0, torque_enable=0)
    assert eeprom.write_eeprom(1, "homing_offset", 4096)  # an earlier give-back, a moment ago
    bus.set(1, "present_position", 4096 + 100)
    line = give_back_turns(io, eeprom, 1, 3 * 4096 + 100)  # booted again at once: 2 turns lost
    assert "+2 whole turns lost at boot: its Homing Offset 4096 -> 12288 is written once its last write" in line
    assert "given back" not in line and homing_writes(bus) == [("write", "homing_offset", (1, 4096))]
    assert eeprom.waiting  # the new offset waits for its time (run_deferred writes it)
