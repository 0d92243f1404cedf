"""Watchdog: which servos get a bus watchdog and with which value, in which order it is written,
and what happens to one that tripped (a fake bus records the writes)."""
from __future__ import annotations

import logging

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.group_io import GroupIO
from dynamixel_handler.core.servo_io import ServoIO
from dynamixel_handler.core.watchdog import WATCHDOG_MAX_MS, Watchdog, WatchdogSettings

from support.fake_bus import H54, XM430, FakeBus, table_of


def watchdog(servos, modes: dict[int, str], settings: WatchdogSettings | None = None, lines: list[str] | None = None,
             tripped_once: bool = True):
    bus = FakeBus(servos)
    table = table_of(bus)
    for dxl_id, mode in modes.items():
        table.set_value("operating_mode", dxl_id, OPERATING_MODES[mode])
    log = logging.getLogger(f"test_watchdog_{id(bus)}")
    if lines is not None:
        log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    io = ServoIO(bus, table, log)
    settings = settings or WatchdogSettings(loop_rate=100.0, every=1, bus_watchdog_ms=500.0, auto_stop=True)
    return bus, table, Watchdog(table, log, io, GroupIO(bus, table, log), settings, tripped_once)


def test_only_servos_in_velocity_current_or_pwm_mode_are_armed_in_two_sync_writes_zero_first():
    bus, table, dog = watchdog({1: XM430, 2: XM430, 3: XM430, 4: H54},
                               {1: "velocity", 2: "position", 3: "pwm", 4: "velocity"})
    table.set_value("bus_watchdog", 1, 0)
    table.set_value("bus_watchdog", 2, 0)
    table.set_value("bus_watchdog", 3, 7)  # armed before (or not known): cleared first, then given the new value
    dog.to_arm.update({1, 2, 3, 4})
    dog.arm_waiting()
    assert bus.item_writes() == [("sync_write", "bus_watchdog", {3: 0}), ("sync_write", "bus_watchdog", {1: 25, 3: 25})]
    assert not dog.to_arm  # the Pro H54 has no bus watchdog; the position-mode servo needs none


def test_the_automatic_value_is_three_loop_gaps_when_that_is_longer_than_the_default():
    _, _, dog = watchdog({1: XM430}, {1: "velocity"},
                         WatchdogSettings(loop_rate=10.0, every=5, bus_watchdog_ms=100.0, auto_stop=True))
    assert dog.watchdog_for(1) == 75  # a read every 5 loops at 10 Hz: 3 x 500 ms = 1500 ms = 75 x 20 ms
    dog.note_loop_period(0.2)          # the loop turns out slower: 3 x 5 x 200 ms
    assert dog.to_arm == {1} and dog.watchdog_for(1) == 127  # the register's most (2540 ms)
    off = watchdog({1: XM430}, {1: "velocity"}, WatchdogSettings(100.0, 1, 500.0, auto_stop=False))[2]
    assert off.watchdog_for(1) == 0    # term/servo_auto_stop off: no automatic watchdog
    assert WATCHDOG_MAX_MS == 127 * 20


def test_a_watchdog_a_command_set_is_kept_in_any_mode_and_raised_to_what_the_loop_needs_with_one_line():
    lines: list[str] = []
    bus, _, dog = watchdog({1: XM430}, {1: "position"},
                           WatchdogSettings(loop_rate=10.0, every=1, bus_watchdog_ms=500.0, auto_stop=True), lines)
    dog.set_user(1, 2)                 # 40 ms asked, the loop reads the servo every 100 ms
    dog.set_user(1, 2)
    assert bus.item_writes()[-1] == ("write", "bus_watchdog", (1, 15))
    assert len([line for line in lines if "shorter than the loop can keep" in line]) == 1
    dog.forget(1)
    assert dog.watchdog_for(1) == 0    # back to the automatic one: none in position mode


def test_a_tripped_watchdog_is_counted_logged_and_re_armed_once_the_reads_saw_it():
    lines: list[str] = []
    bus, table, dog = watchdog({1: XM430, 2: XM430}, {1: "velocity", 2: "velocity"}, lines=lines)
    table.set_value("bus_watchdog", 1, -1)
    table.set_value("bus_watchdog", 2, 25)
    dog.check_due = True
    dog.arm_waiting()
    assert dog.trips == 1
    assert bus.item_writes() == [("write", "bus_watchdog", (1, 0)), ("write", "bus_watchdog", (1, 25))]
    assert lines == ["ID 1: bus watchdog tripped (no instruction within its time): servo stopped, "
                     "watchdog re-armed (500 ms)"]


def test_goals_look_for_trips_once_per_new_watchdog_values_unless_told_to_look_every_time():
    _, table, dog = watchdog({1: XM430}, {1: "velocity"})
    table.set_value("bus_watchdog", 1, 25)
    assert not dog.any_tripped() and not dog.any_tripped()
    table.set_value("bus_watchdog", 1, -1)
    assert dog.any_tripped()
    _, table, every_time = watchdog({1: XM430}, {1: "velocity"}, tripped_once=False)
    table.set_value("bus_watchdog", 1, 25)
    assert every_time.any_tripped()


def test_other_parts_ask_for_an_arming_and_a_check_and_get_them_at_the_next_step():
    bus, table, dog = watchdog({1: XM430, 2: XM430}, {1: "velocity", 2: "velocity"})
    table.set_value("bus_watchdog", 1, 0)
    dog.request_arm(1)  # asked for (a servo set up, or back after a silence): nothing written yet
    dog.check_later()
    assert bus.item_writes() == []
    dog.arm_waiting()
    assert ("sync_write", "bus_watchdog", {1: 25}) in bus.item_writes()
    assert not dog.to_arm and not dog.check_due
