"""The item job (``commands.items_job``) in the Book over a ServoAccess stand-in: reads spread over
the loop's steps (a few transactions each), writes checked as the set-up tool checks them (a servo
with one refused item gets none written), an EEPROM item of a servo holding torque only with
torque_off, items kept for the node's own doors refused, values in units converted to registers."""
from __future__ import annotations

import math

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.items_job import READS_PER_STEP, ItemsJob, Writes
from dynamixel_handler.commands.move_checks import DONE, ERROR
from dynamixel_handler.commands.moves import Book

from support.fake_bus import XM430
from support.servo_access import FakeAccess, attached

VALUES = {"present_temperature": {1: 31, 2: 33}, "temperature_limit": {1: 80, 2: 80}, "torque_enable": {1: 1, 2: 0},
          "min_position_limit": {1: 0, 2: 0}, "max_position_limit": {1: 4095, 2: 4095}, "led": {1: 0, 2: 0}}


def _book(values=VALUES):
    access = FakeAccess({1: XM430, 2: XM430}, values=values)
    return access, attached(Book(access, attached(Commander(access)), None))


def _steps(book, job, most=50) -> int:
    book.add(job)
    for step in range(1, most + 1):
        book.on_step()
        if job.finished:
            return step
    raise AssertionError("the job did not end")


def _writes(access):
    return [c for c in access.calls if c[0] in ("write_item", "write_eeprom", "write_eeprom_many")]


def test_reads_are_spread_over_steps_and_give_units_and_raw():
    access, book = _book()
    job = ItemsJob([1, 2], ["present_temperature", "temperature_limit", "led", "torque_enable"], None, answer_by=1e12)
    steps = _steps(book, job)
    assert steps == math.ceil(8 / READS_PER_STEP) and job.outcome == DONE, job.message
    first = job.results[0]
    assert (first.dxl_id, first.item, first.raw, first.value, first.unit) == (1, "present_temperature", 31, 31.0, "degC")
    assert [r.raw for r in job.results if r.item == "led"] == [0, 0] and math.isnan(job.results[2].value)


def test_an_unknown_item_and_an_unhandled_servo_are_said_per_entry():
    access, book = _book()
    job = ItemsJob([1, 9], ["led", "warp_drive"], None, answer_by=1e12)
    _steps(book, job)
    assert job.outcome == ERROR
    errors = [r.error for r in job.results]
    assert errors[0] == "" and "has no control-table item 'warp_drive'" in errors[1]
    assert errors[2:] == ["not handled by this node"] * 2


def test_a_write_in_units_goes_to_the_register_and_an_eeprom_item_waits_for_torque_off():
    access, book = _book()
    job = ItemsJob([2], ["temperature_limit", "led"], Writes((70.0, 1.0)), answer_by=1e12)
    _steps(book, job)  # servo 2: torque off, so the EEPROM item is written
    assert _writes(access) == [("write_eeprom_many", 2, {"temperature_limit": 70}), ("write_item", 2, "led", 1)]
    access, book = _book()
    job = ItemsJob([1], ["temperature_limit"], Writes((70.0,)), answer_by=1e12)
    _steps(book, job)  # servo 1 holds torque
    assert job.outcome == ERROR and "give torque_off" in job.results[0].error and _writes(access) == []
    job = ItemsJob([1], ["temperature_limit"], Writes((70.0,), torque_off=True), answer_by=1e12)
    _steps(book, job)
    assert _writes(access) == [("write_eeprom_many", 1, {"temperature_limit": 70})]


def test_one_refused_item_keeps_every_item_of_its_servo_unwritten():
    access, book = _book()
    for items, values, why in ((["temperature_limit", "led"], (95.0, 1.0), "lowers a protection"),
                               (["min_position_limit", "led"], (5000.0, 1.0), "is out of range for XM430-W350"),
                               (["goal_position", "led"], (1.0, 1.0), "a goal: give it on the command topics"),
                               (["baud_rate", "led"], (3.0, 1.0), "changes the bus under the node")):
        job = ItemsJob([2], items, Writes(values, raw=items[0] != "temperature_limit"), answer_by=1e12)
        _steps(book, job)
        assert job.outcome == ERROR and why in job.results[0].error, job.results[0].error
        assert job.results[1].error == "not written: another item of this servo was refused"
    assert _writes(access) == []
    job = ItemsJob([2], ["temperature_limit"], Writes((95.0,), force=True), answer_by=1e12)
    _steps(book, job)
    assert _writes(access) == [("write_eeprom_many", 2, {"temperature_limit": 95})]


def test_one_value_per_servo_and_item():
    access, book = _book()
    job = ItemsJob([1, 2], ["led"], Writes((1.0, 0.0), raw=True), answer_by=1e12)
    _steps(book, job)
    assert [c for c in _writes(access)] == [("write_item", 1, "led", 1), ("write_item", 2, "led", 0)]


def test_a_refusal_on_one_servo_writes_nothing_to_any_and_a_slow_profile_is_never_no_limit():
    access, book = _book()
    job = ItemsJob([1, 2], ["led", "temperature_limit"], Writes((1.0, 70.0, 1.0, 70.0)), answer_by=1e12)
    _steps(book, job)  # servo 1 holds torque: its EEPROM item refused, so servo 2 gets nothing either
    assert job.outcome == ERROR and _writes(access) == []
    assert "give torque_off" in job.results[1].error
    assert job.results[2].error == "not written: an item of another servo was refused"
    job = ItemsJob([2], ["profile_velocity"], Writes((0.05,)), answer_by=1e12)  # deg/s: under one step
    _steps(book, job)
    assert _writes(access) == [("write_item", 2, "profile_velocity", 1)]  # the smallest step, not 0


def test_the_eeprom_items_of_one_servo_are_written_in_one_torque_off_window():
    """A restore of several EEPROM items of a servo holding its load turns torque off once, not
    once an item (each time the load sags a little)."""
    access, book = _book()
    job = ItemsJob([1], ["temperature_limit", "max_voltage_limit", "led"], Writes((70.0, 14.0, 1.0), torque_off=True),
                   answer_by=1e12)
    _steps(book, job)
    writes = _writes(access)
    assert [w[0] for w in writes] == ["write_eeprom_many", "write_item"], writes
    assert writes[0][1] == 1 and set(writes[0][2]) == {"temperature_limit", "max_voltage_limit"}
