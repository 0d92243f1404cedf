"""``commands.servo_settings``: status, gains, limits and shortcuts as requests to the core."""
import math

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.servo_settings import SIGNED_LIMITS, SettingsCommands

from support.servo_access import FakeAccess, attached, warnings_of

XM430, H54 = 1020, 54024


def _commander(**kwargs):
    access = FakeAccess({1: XM430, 2: XM430, 3: H54}, **kwargs)
    lines = warnings_of(access)
    return attached(Commander(access)), access, lines


def test_gains_are_written_as_goals_and_clamped_to_the_register():
    c, access, lines = _commander()
    c.gain([1, 2], {"position_p_gain_pulse": [800, 99999]})
    assert access.goals == [{"position_p_gain": {1: 800, 2: 65535}}]
    assert lines == ["ID 2 (XM430-W350) 'position_p_gain_pulse' = 99999 is beyond 65535: clamped to 65535"]
    c.gain([3], {"position_d_gain_pulse": [5]})  # old PRO: no Position D gain
    assert lines[-1] == "gain: ID 3 (H54-200-S500-R) has no position_d_gain: ignored" and len(access.goals) == 1


def test_limits_go_to_eeprom_and_bad_ones_are_refused():
    c, access, lines = _commander(values={"min_position_limit": {1: 0}, "max_position_limit": {1: 4095}})
    c.limit([1], {"temperature_limit_degc": [70.0], "velocity_limit_deg_s": [-1.0]})
    assert ("write_eeprom", 1, "temperature_limit", 70) in access.calls
    assert not any(call[0] == "write_eeprom" and call[2] == "velocity_limit" for call in access.calls)
    assert lines == ["limit: ID 1 'velocity_limit_deg_s' = -1 refused (negative)"]
    c.limit([1], {"min_position_limit_deg": [10.0], "max_position_limit_deg": [-10.0]})
    assert lines[-1] == "limit: ID 1 min position limit above max: position limits ignored"
    assert not any(call[0] == "write_eeprom" and "position_limit" in call[2] for call in access.calls)
    c.limit([1], {"temperature_limit_degc": [math.nan]})
    assert lines[-1] == "limit: ID 1 'temperature_limit_degc' = nan refused (not a finite number)"


def test_status_mode_and_torque():
    c, access, lines = _commander(modes={1: "velocity"})
    c.status([1, 2], {"mode": ["position", "warp"], "torque": [True, False]})
    assert ("change_mode", 1, "position") in access.calls
    assert ("torque_on", 1) in access.calls and ("torque_off", 2) in access.calls
    assert lines[0].startswith("status: ID 2 unknown mode 'warp' (known: current, velocity, position")
    c.status([3], {"mode": ["pwm"]})  # the old PRO has no PWM mode
    assert lines[-1] == "status: ID 3 (H54-200-S500-R) has no 'pwm' mode: ignored"
    assert ("change_mode", 3, "pwm") not in access.calls


def test_ping_alone_asks_for_a_membership_change_per_loop():
    c, access, _ = _commander()
    c.status([2, 9], {"ping": [False, True]})
    assert access.calls == [("want_handled", 2, False), ("want_handled", 9, True)]


def test_shortcuts_act_on_the_named_or_every_servo():
    c, access, lines = _commander()
    c.shortcut("TOFF", [])  # no IDs: every handled servo
    assert [call for call in access.calls if call[0] == "torque_off"] == [("torque_off", 1), ("torque_off", 2),
                                                                         ("torque_off", 3)]
    c.shortcut("reset_offset", [2, 7])
    assert ("write_eeprom", 2, "homing_offset", 0) in access.calls
    assert lines[-1] == "shortcut reset_offset: ID 7 is not handled: ignored"
    c.shortcut("launch", [1])
    assert lines[-1].startswith("shortcut: unknown command 'launch' (known: clear_error, CE, torque_on")
    c.shortcut("remove_id", [3])
    assert access.calls[-1] == ("want_handled", 3, False)


def test_only_the_position_limits_may_be_negative_and_a_gain_for_an_unknown_id_is_not_written():
    c, access, lines = _commander(values={"min_position_limit": {1: 0}, "max_position_limit": {1: 4095}})
    assert isinstance(c, SettingsCommands)
    c.limit([1], {"min_position_limit_deg": [-90.0], "max_position_limit_deg": [90.0], "pwm_limit_percent": [-5.0]})
    written = {call[2]: call[3] for call in access.calls if call[0] == "write_eeprom"}
    assert set(written) == set(SIGNED_LIMITS)  # -90 deg: 1024 pulses, written; a negative PWM limit is not
    assert written == {"min_position_limit": 1024, "max_position_limit": 3072}
    assert lines == ["limit: ID 1 'pwm_limit_percent' = -5 refused (negative)"]
    c.gain([9], {"position_p_gain_pulse": [800]})
    assert access.goals == [] and lines[-1] == "gain: ID 9 is not handled: ignored"
