"""The servos block without a node: names and types read into ServoSetting values (from nested
mappings and from the flattened parameter names), the checks against a model, the register values
an entry asks for, and a snapshot entry that reads back as the same entry."""
from __future__ import annotations

import re

import pytest

from dynamixel_handler.config import defaults, validate
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.errors import ConfigError
from dynamixel_handler.joints import joint_map
from dynamixel_handler.servo.settings import ServoSetting, servo_block, servo_settings
from dynamixel_handler.servo.snapshot import entry_of, servos_yaml
from dynamixel_handler.servo_targets import dangers, refusals, register_values
from dynamixel_handler.settings import Settings

XM430, PH54, XL320 = model_by_number(1020), model_by_number(2020), model_by_number(350)
DEG_S = 0.229 * 6.0
JOINTS = joint_map(False, ["base", "wrist"], [1, 2], [1], [0.0])


def test_an_entry_takes_nested_and_dotted_items_in_their_types():
    s = ServoSetting(1, {"mode": "cur_position", "position_p_gain_pulse": 640.0, "profile_vel_deg_s": 60,
                         "drive_mode": {"reverse_mode": True}, "shutdown.overload_error": False})
    assert s.name == "id_1"
    assert dict(s.values) == {"mode": "cur_position", "position_p_gain_pulse": 640, "profile_vel_deg_s": 60.0,
                              "drive_mode.reverse_mode": True, "shutdown.overload_error": False}
    assert type(s.values["position_p_gain_pulse"]) is int and type(s.values["profile_vel_deg_s"]) is float
    assert s.sets("drive_mode") and not s.sets("velocity_limit")
    with pytest.raises(TypeError):
        s.values["mode"] = "position"  # type: ignore[index]
    assert Settings(servos=(s,)).servos[0] == ServoSetting(1, dict(s.values))


@pytest.mark.parametrize("values, message", [
    ({"position_p_gain": 640}, "servos.id_1.position_p_gain = 640: unknown item: did you mean 'position_p_gain_pulse'?"),
    ({"position_p_gain_pulse": 640.5}, "servos.id_1.position_p_gain_pulse = 640.5: must be int"),
    ({"position_p_gain_pulse": True}, "must be int"),
    ({"velocity_limit_deg_s": "fast"}, "servos.id_1.velocity_limit_deg_s = 'fast': must be float"),
    ({"velocity_limit_deg_s": -1.0}, "must not be negative"),
    ({"mode": "turbo"}, "servos.id_1.mode = turbo: unknown mode"),
    ({"drive_mode": {"profile_configuration": "fast"}}, "must be velocity_based or time_based"),
    ({"led": {"red_percent": 150.0}}, "must be within 0..100 %"),
    ({"drive_mode": {"revers_mode": True}}, "did you mean 'drive_mode.reverse_mode'?"),
])
def test_a_wrong_item_or_type_is_one_line_naming_servo_item_and_value(values, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        ServoSetting(1, values)


def test_entries_are_named_by_id_or_joint_and_each_servo_once():
    entries = servo_settings({"wrist": {"position_p_gain_pulse": 700}, "id_1": {"mode": "position"}}, JOINTS)
    assert [(e.dxl_id, e.name) for e in entries] == [(1, "id_1"), (2, "wrist")]
    with pytest.raises(ConfigError, match="servos.elbow: neither id_<N> nor a joint name .*base, wrist"):
        servo_settings({"elbow": {"mode": "position"}}, JOINTS)
    with pytest.raises(ConfigError, match="joint_state.names maps none"):
        servo_settings({"wrist": {"mode": "position"}})
    with pytest.raises(ConfigError, match="servo ID 2 is also given as servos.wrist"):
        servo_settings({"wrist": {"mode": "position"}, "id_2": {"mode": "position"}}, JOINTS)
    with pytest.raises(ConfigError, match="servo ID 300 is not within 0..252"):
        servo_settings({"id_300": {"mode": "position"}})


def test_the_flattened_parameter_names_make_the_same_entries_and_the_config_holds_them():
    flat = {"servos.id_1.mode": "cur_position", "servos.id_1.drive_mode.reverse_mode": True, "loop_rate": 100}
    assert servo_block(flat) == (ServoSetting(1, {"mode": "cur_position", "drive_mode": {"reverse_mode": True}}),)
    config = validate({**defaults(), **flat, "joint_state.names": ["base"], "joint_state.ids": [1]})
    assert config.settings.servos == servo_block(flat)
    assert validate(defaults()).settings.servos == ()  # no block: nothing changes
    with pytest.raises(ConfigError, match="must be a single value"):
        servo_block({"servos.id_1.position_p_gain_pulse": [1, 2]})
    with pytest.raises(ConfigError, match="one block per servo"):
        servo_block({"servos.id_1": 5})


def test_the_model_refuses_what_it_lacks_and_what_is_beyond_its_e_manual_range():
    ok = ServoSetting(1, {"mode": "cur_position", "velocity_limit_deg_s": 1405.0, "position_p_gain_pulse": 16383,
                          "max_position_limit_deg": 179.0, "led": {"red_percent": 100.0}, "bus_watchdog_ms": 100.0})
    assert refusals(XM430, ok) == []
    bad = ServoSetting(2, {"velocity_limit_deg_s": 1500.0, "position_p_gain_pulse": 16384, "led": {"green_percent": 1.0},
                           "max_position_limit_deg": 400.0, "return_delay_time_us": 600.0})
    lines = refusals(XM430, bad)
    assert lines == [
        "servos.id_2.velocity_limit_deg_s = 1500.0: ID 2 (XM430-W350) is outside its e-Manual range 0..1405.6",
        "servos.id_2.position_p_gain_pulse = 16384: ID 2 (XM430-W350) is outside its e-Manual range 0..16383",
        "servos.id_2.led.green_percent = 1.0: ID 2 (XM430-W350) has no led",
        "servos.id_2.max_position_limit_deg = 400.0: ID 2 (XM430-W350) is outside its e-Manual range -180..179.912",
        "servos.id_2.return_delay_time_us = 600.0: ID 2 (XM430-W350) is outside its e-Manual range 0..508",
    ]
    assert refusals(PH54, ServoSetting(3, {"mode": "cur_position"})) == [
        "servos.id_3.mode = cur_position: ID 3 (PH54-200-S500-R) has no 'cur_position' mode (its modes: current, "
        "ex_position, position, pwm, velocity)"]
    assert "has no profile_velocity" in refusals(XL320, ServoSetting(4, {"profile_vel_deg_s": 10.0}))[0]
    assert refusals(XL320, ServoSetting(4, {"mode": "velocity", "led": {"blue_percent": 100.0}})) == []


def test_the_register_values_in_pulses_bits_merged_with_the_servo_s():
    entry = ServoSetting(1, {"mode": "cur_position", "velocity_limit_deg_s": 120.0, "position_p_gain_pulse": 640,
                             "drive_mode": {"reverse_mode": True}, "shutdown": {"overload_error": False},
                             "led": {"red_percent": 100.0}, "bus_watchdog_ms": 5.0, "homing_offset_deg": -9.0})
    held = {"drive_mode": 0x04, "shutdown": 0x34}  # time-based profile; overheating, shock, overload
    values = register_values(XM430, entry, held.get)
    assert values == {"operating_mode": 5, "velocity_limit": round(120.0 / DEG_S), "position_p_gain": 640,
                      "led": 1, "bus_watchdog": 1, "homing_offset": round(-9.0 / 0.088), "drive_mode": 0x05,
                      "shutdown": 0x14}
    p = register_values(PH54, ServoSetting(2, {"led": {"red_percent": 50.0, "blue_percent": 100.0}}), lambda _: None)
    assert p == {"led_red": 128, "led_blue": 255}
    xl = register_values(XL320, ServoSetting(3, {"led": {"green_percent": 100.0}}), lambda _: 1)
    assert xl == {"led_colour": 3}  # red kept on, green on


def test_a_snapshot_entry_loads_back_as_the_entry_the_servo_holds():
    held = {"position_p_gain": 640, "velocity_limit": 87, "profile_velocity": 44, "homing_offset": -102,
            "return_delay_time": 10, "drive_mode": 0x01, "shutdown": 0x14, "max_position_limit": 4095}
    def read(item: str) -> int:
        return held.get(item, XM430.factory.get(item, 0))
    entry = entry_of(XM430, read, "cur_position")
    assert entry["mode"] == "cur_position" and entry["position_p_gain_pulse"] == 640
    assert entry["drive_mode"] == {"reverse_mode": True, "profile_configuration": "velocity_based",
                                   "torque_on_by_goal_update": False}
    assert entry["shutdown"]["overload_error"] is False and entry["shutdown"]["overheating_error"] is True
    setting = ServoSetting(1, entry)
    assert refusals(XM430, setting) == []
    again = register_values(XM430, setting, read)
    assert {k: again[k] for k in held} == held
    text = servos_yaml([(1, entry)], "/dev/ttyUSB0")
    assert text.startswith("# the servos' settings as read from /dev/ttyUSB0") and "id_1:" in text


def test_the_set_up_tools_checks_judge_what_an_entry_would_change():
    held = {"shutdown": 52, "drive_mode": 0, "temperature_limit": 80, "min_position_limit": 0, "max_position_limit": 4095}
    lowered = ServoSetting(1, {"shutdown": {"overload_error": False}, "temperature_limit_degc": 90.0})
    refused, forced = dangers(XM430, lowered, held.get, [1, 2])
    assert sorted(refused) == ["shutdown", "temperature_limit"] and not forced
    assert "clears protection bits 0x20" in refused["shutdown"] and "give 'force: true'" in refused["shutdown"]
    refused, forced = dangers(XM430, ServoSetting(1, lowered.values, force=True), held.get, [1, 2])
    assert not refused and len(forced) == 2 and all(line.endswith("written (force: true)") for line in forced)
    # what the servo already holds is no change: no force needed (a snapshot loads back)
    assert dangers(XM430, lowered, {**held, "shutdown": 52 & ~0x20, "temperature_limit": 90}.get) == ({}, [])
    # min not below max: refused even with force
    inverted = ServoSetting(1, {"min_position_limit_deg": 90.0, "max_position_limit_deg": -90.0}, force=True)
    refused, _ = dangers(XM430, inverted, held.get)
    assert list(refused) == ["min_position_limit"] and "would not be below max_position_limit" in refused["min_position_limit"]


@pytest.mark.parametrize("name", ["id_\u00b2", "id_\u0662", "id_1.5", "id_-1"])
def test_an_entry_name_is_id_and_ascii_digits_only(name):
    with pytest.raises(ConfigError, match="neither id_<N> nor a joint name"):
        servo_settings({name: {"position_p_gain_pulse": 640}})


def test_a_number_beyond_any_register_and_a_force_that_is_no_bool_are_refused():
    with pytest.raises(ConfigError, match=r"position_p_gain_pulse = 1e\+308: beyond any register"):
        ServoSetting(1, {"position_p_gain_pulse": 1e308})
    with pytest.raises(ConfigError, match="servos.id_1.force = 'yes': must be true or false"):
        ServoSetting(1, {"force": "yes"})
    assert ServoSetting(1, {"force": True, "position_p_gain_pulse": 640}).force is True
