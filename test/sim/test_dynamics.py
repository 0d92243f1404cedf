"""Dynamics: the shaft behind the goal registers, the present values it writes, the bus watchdog."""
from __future__ import annotations

import pytest

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.sim.defaults import factory_defaults
from dynamixel_handler.sim.dynamics import Dynamics
from dynamixel_handler.sim.registers import RegisterFile, Registers

XM430 = 1020


@pytest.fixture
def shaft() -> tuple[Registers, Dynamics]:
    model = model_by_number(XM430)
    defaults = factory_defaults(model, 1)
    r = Registers(model, RegisterFile(model, defaults["firmware_version"]), True)
    for name, value in defaults.items():
        r.poke(name, value)
    return r, Dynamics(r, 100.0)


def test_velocity_mode_turns_the_shaft_at_the_goal_velocity(shaft):
    r, dynamics = shaft
    r.poke("operating_mode", 1)
    r.poke("goal_velocity", 100)
    r.poke("torque_enable", 1)
    dynamics.refresh(101.0)
    assert r.peek("present_velocity") == 100
    start = r.peek("present_position")
    dynamics.refresh(102.0)
    moved = r.peek("present_position") - start
    # 100 x 0.229 rpm = 22.9 rpm = 0.382 rev/s = 1563 pulses/s
    assert moved == pytest.approx(1563, rel=0.02)
    assert r.peek("moving") == 1


def test_torque_off_stops_the_shaft(shaft):
    r, dynamics = shaft
    r.poke("operating_mode", 1)
    r.poke("goal_velocity", 100)
    r.poke("torque_enable", 1)
    dynamics.refresh(101.0)
    r.poke("torque_enable", 0)
    dynamics.torque_changed(1, 0, 101.0)
    dynamics.refresh(102.0)
    assert r.peek("present_velocity") == 0 and r.peek("moving") == 0


def test_an_armed_watchdog_trips_without_instructions(shaft):
    r, dynamics = shaft
    r.poke("operating_mode", 1)
    r.poke("torque_enable", 1)
    r.poke("goal_velocity", 50)
    r.poke("bus_watchdog", 5)  # 100 ms
    dynamics.last_instruction = 100.0
    dynamics.refresh(100.05)
    assert r.peek("bus_watchdog") == 5
    dynamics.refresh(100.2)
    assert r.peek("bus_watchdog") == -1 and r.peek("goal_velocity") == 0
    assert r.peek("present_velocity") == 0


def test_a_pinned_value_is_what_the_register_says(shaft):
    r, dynamics = shaft
    dynamics.pinned["present_temperature"] = 70
    dynamics.refresh(101.0)
    assert r.peek("present_temperature") == 70


def test_the_realtime_tick_counts_milliseconds_since_the_power_cycle(shaft):
    r, dynamics = shaft
    dynamics.refresh(100.5)
    assert r.peek("realtime_tick") == 500
    dynamics.restart(100.5)
    dynamics.refresh(100.75)
    assert r.peek("realtime_tick") == 250


def test_a_shaft_turned_by_hand_reads_the_angle_asked_with_homing_offset_and_reverse():
    from dynamixel_handler.sim import VirtualBus
    from dynamixel_handler.sim.cli import run_command

    with VirtualBus({1: XM430, 2: XM430}, wire_timing=False) as bus:
        assert run_command(bus, "turn 1 -45") == "ok"
        assert bus.servo(1).read("present_position") == 2048 - 512  # 0.088 deg per pulse, 0 deg at 2048
        servo = bus.servo(2)
        servo.write("homing_offset", 100)
        servo.write("drive_mode", 1)  # reverse: the shaft counts the other way, Homing Offset added after
        bus.turn(2, 30.0)
        assert servo.read("present_position") == 2048 + 341
        assert run_command(bus, "turn 3 10").startswith("error: ")
        assert run_command(bus, "turn 1 inf").startswith("error: ")


def test_a_protocol1_shaft_turned_by_hand_stays_within_its_sensor_s_range():
    from dynamixel_handler.sim import VirtualBus

    with VirtualBus({7: 12}, wire_timing=False) as bus:  # an AX-12A: 0 deg at 512, 0.29 deg per pulse
        bus.turn(7, 60.0)
        servo = bus.servos_at(7)[0]
        assert servo.read("present_position") == 512 + 205
        bus.turn(7, 400.0)
        assert servo.read("present_position") == 1023
