"""ServoSetup on its own over the real parts it calls (``support.parts``, a fake bus): a default
profile beyond what a P servo takes lowered to its limit with one line, the servos block's return
delay kept, a Protocol 1.0 servo's default speed in its Moving Speed, torque and the error clear as
the parameters say, and the whole turns a multi-turn servo lost given back. (test_startup_part.py
asks the same of the start-up that calls it.)"""
from __future__ import annotations

import logging

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.servo_setup import ServoSetup, SetupSettings
from dynamixel_handler.settings import ScanSettings, Settings, StartValues

from support.fake_bus import PH54, XM430, FakeBus
from support.parts import Parts, build, lines_of

AX12A = 12


def handled(bus: FakeBus, name: str, **changes) -> tuple[Parts, ServoSetup, list[str]]:
    """The parts over ``bus`` with every servo of it in the table, as the start-up leaves them."""
    log, lines = lines_of(f"test_servo_setup.{name}", logging.INFO)
    parts = build(bus, Settings().but(**changes), log)
    for dxl_id, model in sorted(bus.models.items()):
        parts.table.add(dxl_id, model)
    return parts, parts.setup, lines


def writes_of(bus: FakeBus, item: str) -> list[tuple[int, int]]:
    return [w[2] for w in bus.item_writes() if w[1] == item]


def test_the_settings_slice_is_the_scan_switches_and_the_start_values():
    start = StartValues(profile_acc=100.0, profile_vel=50.0, return_delay_time=4.0)
    scan = ScanSettings(hardware_error_auto_clean=False, torque_auto_enable=False)
    assert SetupSettings.of(scan, start) == SetupSettings(False, False, start)


def test_a_default_profile_beyond_a_p_servos_velocity_limit_is_set_to_the_limit_with_one_line():
    bus = FakeBus({1: PH54})
    bus.set(1, "velocity_limit", 300)
    bus.set(1, "acceleration_limit", 0)  # no limit set: the e-Manual range alone bounds it
    _, setup, lines = handled(bus, "p limit", scan__used_series=("P",), scan__torque_auto_enable=False,
                              start__profile_vel=1000.0)
    setup.setup_servo(1)
    assert writes_of(bus, "profile_velocity") == [(1, 300)]
    lowered = [line for line in lines if "default/profile_vel" in line]
    assert len(lowered) == 1 and lowered[0].startswith("ID 1 (PH54-200-S500-R): default/profile_vel = 1000 is beyond")
    assert "profile_velocity set to" in lowered[0]
    assert not [line for line in lines if "default/profile_acc" in line]  # within its range: no line


def test_a_protocol1_servo_in_joint_mode_gets_the_default_speed_as_its_moving_speed():
    bus = FakeBus({}, protocol1={4: AX12A})
    bus.set(4, "min_position_limit", 0)  # CW / CCW Angle Limit apart: joint mode, where a Moving
    bus.set(4, "max_position_limit", 1023)  # Speed of 0 means as fast as the motor goes
    _, setup, _ = handled(bus, "protocol 1", scan__used_series=("X", "AX"), scan__torque_auto_enable=False,
                          scan__hardware_error_auto_clean=False, start__profile_vel=60.0)
    setup.setup_servo(4)
    (written,) = writes_of(bus, "goal_velocity")  # the canonical name of its Moving Speed
    assert written == (4, 90)  # 60 deg/s = 10 rpm, at 0.111 rpm a unit
    assert not writes_of(bus, "profile_velocity")


def test_a_hardware_error_found_at_set_up_is_cleared_by_a_reboot_with_one_warning():
    bus = FakeBus({1: XM430})
    bus.set(1, "hardware_error_status", 0x20)
    _, setup, lines = handled(bus, "clean", scan__torque_auto_enable=False)
    setup.setup_servo(1)
    assert [c[1] for c in bus.of("reboot")] == [1]
    assert "ID 1: hardware error 0x20 at start-up: clearing it by reboot" in lines


def test_without_the_error_clean_switch_an_error_is_left_and_the_torque_as_told():
    bus = FakeBus({1: XM430})
    bus.set(1, "hardware_error_status", 0x20)
    _, setup, lines = handled(bus, "no clean", scan__hardware_error_auto_clean=False, scan__torque_auto_enable=True)
    setup.setup_servo(1)
    assert not bus.of("reboot") and not [line for line in lines if "hardware error" in line]
    assert writes_of(bus, "torque_enable") == [(1, 1)]


def test_the_whole_turns_a_multi_turn_servo_lost_are_given_back_and_a_one_turn_servo_is_left_alone():
    bus = FakeBus({1: XM430, 2: XM430})
    for dxl_id, mode in ((1, "ex_position"), (2, "position")):
        bus.set(dxl_id, "operating_mode", OPERATING_MODES[mode])
        bus.set(dxl_id, "present_position", 100)
        bus.set(dxl_id, "torque_enable", 0)
    _, setup, lines = handled(bus, "turns")
    setup.give_back_turns(1, 3 * 4096 + 100)
    setup.give_back_turns(2, 3 * 4096 + 100)
    assert writes_of(bus, "homing_offset") == [(1, 3 * 4096)]
    assert len([line for line in lines if "whole turns lost at boot given back" in line]) == 1
