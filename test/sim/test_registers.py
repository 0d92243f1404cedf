"""Registers: a servo's values by item name over its register file (bytes where the control table
puts them, signed per item)."""
from __future__ import annotations

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.sim.registers import RegisterFile, Registers

XM430, H54 = 1020, 54024


def registers(number: int) -> Registers:
    model = model_by_number(number)
    return Registers(model, RegisterFile(model, 45), model.family.x_table)


def test_a_value_lands_little_endian_at_its_address_and_reads_back_signed():
    r = registers(XM430)
    r.poke("goal_position", -2)
    goal = r.model.item("goal_position")
    assert bytes(r.regs[goal.address:goal.address + 4]) == b"\xfe\xff\xff\xff"
    assert r.peek("goal_position") == -2


def test_a_value_too_wide_for_its_item_keeps_its_low_bytes():
    r = registers(XM430)
    r.poke("led", 0x101)
    assert r.peek("led") == 1


def test_an_item_the_model_lacks_is_not_written_and_reads_as_the_default():
    r = registers(H54)  # old PRO: no bus watchdog
    before = bytes(r.regs)
    r.poke("bus_watchdog", 5)
    assert bytes(r.regs) == before
    assert not r.has("bus_watchdog") and r.get("bus_watchdog", -7) == -7


def test_the_x_table_flag_follows_the_family():
    assert registers(XM430).x and not registers(H54).x
