"""Shutdown: what the servos are left as, and the order of the writes (a fake bus records them)."""
from __future__ import annotations

import logging

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.group_io import GroupIO
from dynamixel_handler.core.servo_io import ServoIO
from dynamixel_handler.core.shutdown import Shutdown
from dynamixel_handler.settings import TermSettings

from support.fake_bus import XM430, FakeBus, table_of


def shutdown(term: TermSettings):
    bus = FakeBus({1: XM430, 2: XM430, 3: XM430})
    table = table_of(bus)
    for dxl_id, mode in ((1, "velocity"), (2, "position"), (3, "current")):
        bus.set(dxl_id, "operating_mode", OPERATING_MODES[mode])
        bus.set(dxl_id, "torque_enable", 1)
        table.set_value("operating_mode", dxl_id, OPERATING_MODES[mode])
    for dxl_id, pulses in ((1, 25), (2, 0), (3, 30)):
        table.set_value("bus_watchdog", dxl_id, pulses)
    bus.set(2, "present_position", 5000)  # beyond its limit: held at the limit
    bus.set(2, "max_position_limit", 4095)
    log = logging.getLogger("test_shutdown")
    return bus, Shutdown(bus, table, log, ServoIO(bus, table, log), GroupIO(bus, table, log), term)


def test_torque_auto_disable_stops_the_moving_modes_then_switches_torque_off_then_the_watchdogs():
    bus, part = shutdown(TermSettings(torque_auto_disable=True, servo_auto_stop=True))
    part.shutdown(dropped=(), user_watchdog={3})
    assert bus.item_writes() == [
        ("sync_write", "goal_velocity", {1: 0}),
        ("sync_write", "goal_current", {3: 0}),
        ("sync_write", "torque_enable", {1: 0, 2: 0, 3: 0}),
        ("sync_write", "bus_watchdog", {1: 0}),  # servo 3's watchdog a command set: left as it is
    ]


def test_servo_auto_stop_alone_holds_every_servo_where_it_is_with_torque_off_and_on_again():
    bus, part = shutdown(TermSettings(torque_auto_disable=False, servo_auto_stop=True))
    part.shutdown()
    writes = bus.item_writes()
    assert writes[:2] == [("sync_write", "goal_velocity", {1: 0}), ("sync_write", "goal_current", {3: 0})]
    assert writes[2] == ("sync_write", "goal_position", {1: 0, 2: 4095, 3: 0})  # := present position, in its limits
    assert writes[3:] == [("sync_write", "torque_enable", {1: 0, 2: 0, 3: 0}),
                          ("sync_write", "torque_enable", {1: 1, 2: 1, 3: 1}),
                          ("sync_write", "bus_watchdog", {1: 0, 3: 0})]


def test_nothing_is_written_when_term_asks_for_nothing_and_on_a_closed_bus():
    bus, part = shutdown(TermSettings(torque_auto_disable=False, servo_auto_stop=False))
    part.shutdown()
    assert bus.item_writes() == [("sync_write", "bus_watchdog", {1: 0, 3: 0})]
    bus, part = shutdown(TermSettings(torque_auto_disable=True, servo_auto_stop=True))
    bus.is_open = False
    part.shutdown(dropped={2})
    assert bus.calls == []
