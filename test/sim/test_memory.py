"""Memory: what a power cycle keeps and resets, factory reset's options, Control Table Backup,
the saved EEPROM."""
from __future__ import annotations

import pytest

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.protocol import servo as p
from dynamixel_handler.sim.defaults import factory_defaults
from dynamixel_handler.sim.memory import Memory
from dynamixel_handler.sim.registers import RegisterFile, Registers

XM430, H54 = 1020, 54024


@pytest.fixture
def parts():
    def make(number: int = XM430, dxl_id: int = 3) -> tuple[Registers, Memory]:
        model = model_by_number(number)
        defaults = factory_defaults(model, dxl_id)
        r = Registers(model, RegisterFile(model, defaults["firmware_version"]), model.family.x_table)
        for name, value in defaults.items():
            r.poke(name, value)
        r.file.factory_indirect()
        return r, Memory(r, defaults)
    return make


def test_a_power_cycle_resets_ram_and_keeps_eeprom_and_indirect_addresses(parts):
    r, memory = parts()
    r.poke("led", 1)
    r.poke("return_delay_time", 0)
    entry = r.file.indirect_addresses[0]
    r.file.poke(entry, 132)
    memory.power_cycle()
    assert r.peek("led") == 0
    assert r.peek("return_delay_time") == 0
    assert r.file.peek(entry) == 132


def test_factory_reset_keeps_what_its_option_says(parts):
    r, memory = parts(dxl_id=7)
    r.poke("baud_rate", 3)
    r.poke("return_delay_time", 0)
    memory.factory_values(0x02)
    assert (r.peek("id"), r.peek("baud_rate"), r.peek("return_delay_time")) == (7, 3, 250)
    memory.factory_values(0x01)
    assert (r.peek("id"), r.peek("baud_rate")) == (7, 1)
    memory.factory_values(0xFF)
    assert r.peek("id") == 1


def test_a_backup_restored_brings_back_the_eeprom_but_not_the_id(parts):
    r, memory = parts(dxl_id=5)
    assert memory.backup(b"\x02CTRL") == p.ERR_RESULT_FAIL  # nothing stored yet
    assert memory.backup(b"\x01CTRL") == p.ERR_NONE and r.peek("backup_ready") == 1
    r.poke("return_delay_time", 0)
    r.poke("id", 9)
    assert memory.backup(b"\x02CTRL") == p.ERR_NONE
    assert r.peek("return_delay_time") == 250 and r.peek("id") == 9


def test_a_backup_is_refused_with_torque_on_or_a_wrong_key(parts):
    r, memory = parts()
    assert memory.backup(b"\x01CTRX") == p.ERR_DATA_RANGE
    r.poke("torque_enable", 1)
    assert memory.backup(b"\x01CTRL") == p.ERR_ACCESS


def test_a_model_without_backup_does_not_know_the_instruction(parts):
    _, memory = parts(H54)
    assert memory.backup(b"\x01CTRL") == p.ERR_INSTRUCTION


def test_the_saved_eeprom_comes_back_into_another_servo(parts):
    r, memory = parts(dxl_id=4)
    r.poke("return_delay_time", 10)
    memory.backup(b"\x01CTRL")
    saved = memory.state()
    other_r, other = parts(dxl_id=1)
    other.load(saved)
    assert other_r.peek("id") == 4 and other_r.peek("return_delay_time") == 10
    other.power_cycle()
    assert other_r.peek("backup_ready") == 1
