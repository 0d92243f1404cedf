"""KeptSettings (the servos block on the servos) over a fake bus, built as the Handler builds its
parts: the check after the scan, the order of the set-up's writes, EEPROM spared, the RAM items put
back after a mode change and a reboot, and nothing put back for a servo without an entry."""
from __future__ import annotations

import logging

import pytest

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.kept_settings import KeptSettings
from dynamixel_handler.core.request_types import Outcome
from dynamixel_handler.errors import ConfigError
from dynamixel_handler.servo.settings import ServoSetting
from dynamixel_handler.settings import LoopSettings, ScanSettings, Settings

from support.fake_bus import PH54, XM430, FakeBus
from support.parts import build, lines_of

DEG_S = 0.229 * 6.0
ENTRY = ServoSetting(1, {"mode": "cur_position", "position_p_gain_pulse": 640, "velocity_limit_deg_s": 120.0,
                         "profile_vel_deg_s": 60.0, "drive_mode": {"reverse_mode": True}}, force=True)


def started(servos=None, entries=(ENTRY,), debug=False, name="test_kept_settings"):
    bus = FakeBus(servos or {1: XM430, 2: XM430})
    for dxl_id in bus.models:
        bus.set(dxl_id, "operating_mode", OPERATING_MODES["position"])
        bus.set(dxl_id, "max_position_limit", 4095)
        bus.set(dxl_id, "position_p_gain", 800)
    log, lines = lines_of(name, logging.INFO)
    settings = Settings(scan=ScanSettings(max_id=3, used_series=("X", "P")), servos=tuple(entries),
                        loop=LoopSettings(mode_change_interval_s=0.0, clear_error_interval_s=0.0, debug=debug))
    parts = build(bus, settings, log)
    return bus, parts, lines


def test_the_set_up_writes_eeprom_then_mode_then_defaults_then_ram_then_torque():
    bus, parts, lines = started()
    bus.set(1, "torque_enable", 1)
    bus.set(1, "return_delay_time", 250)
    parts.startup.start()
    writes = [w[1] for w in bus.item_writes() if w[2][0] == 1]
    assert writes == ["torque_enable", "velocity_limit", "drive_mode",   # EEPROM with torque off
                      "operating_mode",                                 # the mode
                      "goal_position", "torque_enable",                 # torque back on as it was, safely
                      "torque_enable", "return_delay_time", "goal_position", "torque_enable",  # the start values
                      "profile_acceleration",                           # not in the entry
                      "position_p_gain", "profile_velocity",            # the entry's RAM items
                      "goal_position", "torque_enable"]                 # torque on: goal := present first
    assert bus.get(1, "operating_mode") == 5 and bus.get(1, "position_p_gain") == 640
    assert bus.get(1, "velocity_limit") == round(120.0 / DEG_S) and bus.get(1, "drive_mode") & 1
    assert bus.get(2, "position_p_gain") == 800  # no entry: untouched
    [line] = [x for x in lines if "servos.id_1 set" in x]
    assert line == ("ID 1 (XM430-W350): servos.id_1 set: velocity_limit_deg_s 120.0 (EEPROM, written), "
                    "drive_mode.reverse_mode True (EEPROM, written), mode cur_position, position_p_gain_pulse 640, "
                    "profile_vel_deg_s 60.0; read back")


def test_a_second_set_up_writes_no_eeprom_item_that_is_already_so():
    bus, parts, lines = started()
    parts.startup.start()
    bus.calls.clear()
    parts.setup.setup_servo(1)
    assert [w[1] for w in bus.item_writes() if w[2][0] == 1] == [
        "profile_acceleration", "position_p_gain", "profile_velocity", "goal_position", "torque_enable"]  # RAM only
    assert "velocity_limit_deg_s 120.0 (EEPROM, already so)" in lines[-1] and "mode cur_position (already so)" in lines[-1]


def test_the_ram_items_come_back_after_a_mode_change_and_a_reboot_not_the_mode():
    bus, parts, lines = started()
    assert isinstance(parts.setup.kept, KeptSettings)
    kept = parts.setup.kept  # one servos block, given at construction to each part that puts it back
    assert parts.requests.kept is kept and parts.reboots.kept is kept and parts.startup.kept is kept
    parts.startup.start()
    bus.set(1, "position_p_gain", 800)  # what the firmware does on a mode change
    assert parts.requests.change_mode(1, "position", "test").outcome is Outcome.DONE
    assert bus.get(1, "operating_mode") == 3 and bus.get(1, "position_p_gain") == 640
    assert lines[-2] == "ID 1: servos.id_1 put back after the mode change to position: position_p_gain_pulse 640, " \
                        "profile_vel_deg_s 60.0"
    bus.set(1, "position_p_gain", 800)
    bus.set(1, "profile_velocity", 0)
    assert parts.reboots.reboot(1)
    assert bus.get(1, "position_p_gain") == 640 and bus.get(1, "profile_velocity") == round(60.0 / DEG_S)
    assert any("put back after a reboot" in x for x in lines)
    bus.calls.clear()
    parts.reboots.reboot(2)  # no entry: nothing of the block written
    assert "position_p_gain" not in [w[1] for w in bus.item_writes()]


def test_refusals_are_one_line_each_and_stop_before_any_write():
    bus, parts, lines = started(servos={1: XM430, 2: PH54}, entries=(
        ServoSetting(1, {"velocity_limit_deg_s": 5000.0}), ServoSetting(2, {"mode": "cur_position"}),
        ServoSetting(5, {"mode": "position"})))
    with pytest.raises(ConfigError, match="the servos block has 3 refused items"):
        parts.startup.start()
    assert [x.split(":")[0] for x in lines if x.startswith("servos.")] == [
        "servos.id_1.velocity_limit_deg_s = 5000.0", "servos.id_2.mode = cur_position", "servos.id_5"]
    assert bus.item_writes() == []
    bus, parts, lines = started(entries=(ServoSetting(1, {"velocity_limit_deg_s": 5000.0}),))
    with pytest.raises(ConfigError, match=r"^servos.id_1.velocity_limit_deg_s = 5000.0: .*: nothing was written$"):
        parts.startup.start()


def test_with_debug_a_refusal_is_a_warning_and_the_rest_is_applied():
    bus, parts, lines = started(entries=(ServoSetting(1, {"position_p_gain_pulse": 640, "velocity_limit_deg_s": 5000.0}),
                                         ServoSetting(6, {"position_p_gain_pulse": 640})), debug=True)
    velocity_limit = bus.get(1, "velocity_limit")
    parts.startup.start()
    assert any("servos.id_6: ID 6 is not on the bus" in x and "debug: left out, running on" in x for x in lines)
    assert any("servos.id_1.velocity_limit_deg_s = 5000.0" in x and "debug: left out" in x for x in lines)
    assert bus.get(1, "position_p_gain") == 640 and bus.get(1, "velocity_limit") == velocity_limit
    assert "velocity_limit" not in [w[1] for w in bus.item_writes()]


def test_an_ax_entry_s_speed_of_a_move_is_moving_speed_and_never_turns_it_in_wheel_mode():
    """AX-12A (Protocol 1.0): the entry's profile_vel_deg_s goes to Moving Speed in Joint Mode; after a
    switch to Wheel Mode (where Moving Speed is the velocity goal) it is not put back, so the shaft
    stays still."""
    bus = FakeBus({}, protocol1={4: 12})
    bus.set(4, "max_position_limit", 1023)
    log, _ = lines_of("test_kept_settings.ax", logging.INFO)
    entry = ServoSetting(4, {"mode": "position", "profile_vel_deg_s": 30.0})
    settings = Settings(scan=ScanSettings(max_id=5, used_series=("AX",)), servos=(entry,),
                        loop=LoopSettings(mode_change_interval_s=0.0))
    parts = build(bus, settings, log)
    parts.startup.start()
    assert bus.get(4, "goal_velocity") == round(30.0 / (0.111 * 6.0))
    assert parts.requests.change_mode(4, "velocity", "test").outcome is Outcome.DONE
    assert (bus.get(4, "min_position_limit"), bus.get(4, "max_position_limit")) == (0, 0)
    assert bus.get(4, "goal_velocity") == 0
