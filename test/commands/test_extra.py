"""``commands.extra``: the DynamixelExtra fields as writes, bit fields changed bit by bit."""
from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.extra import PWM_SLOPE_RANGE, apply_extra

from support.servo_access import FakeAccess, attached, warnings_of

XM430, PH54, XC330_T181 = 1020, 2020, 1210


def _commander(**kwargs):
    access = FakeAccess({1: XM430, 2: PH54}, **kwargs)
    lines = warnings_of(access)
    return attached(Commander(access)), access, lines


def test_leds_by_family_x_one_led_p_three_colours():
    c, access, lines = _commander()
    c.extra([1, 2], {"led.red_percent": [60.0, 50.0], "led.green_percent": [0.0, 200.0]})
    assert ("write_item", 1, "led", 1) in access.calls
    assert ("write_item", 2, "led_red", 128) in access.calls and ("write_item", 2, "led_green", 255) in access.calls
    assert lines == ["extra: ID 1 (XM430-W350) has no green LED: ignored"]


def test_drive_mode_changes_the_bits_given_and_keeps_the_others():
    c, access, _ = _commander(values={"drive_mode": {1: 0x01 | 0x02}})  # reverse on, bit 1 (not ours) set
    c.extra([1], {"drive_mode.profile_configuration": ["time_based"]})
    assert access.calls == [("write_eeprom", 1, "drive_mode", 0x01 | 0x02 | 0x04)]


def test_out_of_range_negative_and_read_only_values_are_refused():
    c, access, lines = _commander()
    c.extra([1], {"bus_watchdog_ms": [-20.0], "shadow_id": [300.0], "model": ["X"],
                  "pwm_slope_percent": [10.0]})
    assert lines == ["extra: 'model' is read-only: ignored",
                     "extra: ID 1 'shadow_id' = 300 is out of range: refused",
                     "extra: ID 1 'bus_watchdog_ms' = -20 refused (negative; 0 switches the watchdog off)",
                     "extra: ID 1 (XM430-W350) has no pwm_slope (X330 only): ignored"]
    assert not access.calls


def test_a_bus_watchdog_time_goes_to_the_core_and_rounds_up_to_one_unit():
    c, access, _ = _commander()
    c.extra([1, 2], {"bus_watchdog_ms": [5.0, 100.0]})
    assert access.calls == [("set_user_watchdog", 1, 1), ("set_user_watchdog", 2, 5)]


def test_a_value_beyond_what_the_register_can_hold_is_refused_not_written_at_its_maximum():
    c, access, lines = _commander()
    c.extra([1], {"return_delay_time_us": [1e6]})  # 2 us a unit, one byte: 508 us at most
    assert lines == ["extra: ID 1 'return_delay_time_us' = 1e+06 is out of range: refused"]
    assert not access.calls
    c.extra([1], {"return_delay_time_us": [100.0]})
    assert access.calls == [("write_eeprom", 1, "return_delay_time", 50)]


def test_the_pwm_slope_of_an_x330_is_written_within_its_register_range_and_refused_beyond():
    """``apply_extra`` on its own, with a Commander for its checks: the X330's PWM slope register."""
    access = FakeAccess({1: XC330_T181, 2: XM430})
    lines = warnings_of(access)
    checks = attached(Commander(access))
    low, high = PWM_SLOPE_RANGE
    apply_extra(checks, [1, 2], {"pwm_slope_percent": [float(high), 10.0]}, "x/extra")
    assert access.calls == [("write_eeprom", 1, "pwm_slope", high)]
    assert lines == ["x/extra: ID 2 (XM430-W350) has no pwm_slope (X330 only): ignored"]
    apply_extra(checks, [1], {"pwm_slope_percent": [float(high + 1)]}, "x/extra")
    apply_extra(checks, [1], {"pwm_slope_percent": [float(low - 1)]}, "x/extra")
    assert lines[-2:] == [f"x/extra: ID 1 'pwm_slope_percent' = {high + 1} is out of range {low}..{high}: refused",
                          f"x/extra: ID 1 'pwm_slope_percent' = {low - 1} is out of range {low}..{high}: refused"]
    assert len(access.calls) == 1
