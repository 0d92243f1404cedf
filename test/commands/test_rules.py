"""``commands.rules``: one implementation of each rule (known IDs, finite values, bounds, clamping)."""
import math

import numpy as np

from dynamixel_handler.commands.goal_bounds import TableBounds
from dynamixel_handler.commands.rules import Rules, all_finite, fits
from dynamixel_handler.control_table import PRO, X

from support.servo_access import FakeAccess

XM430, XL430, PH54, H54 = 1020, 1060, 2020, 54024


def _rules(access: FakeAccess, bounds: bool = True) -> tuple[Rules, list[str]]:
    lines: list[str] = []
    return Rules(access, lines.append, TableBounds(bounds)), lines


def test_fits_asks_handled_and_of_the_family():
    access = FakeAccess({1: XM430, 2: H54})
    assert fits(access, 1, None) and fits(access, 1, X) and not fits(access, 1, PRO)
    assert fits(access, 2, PRO) and not fits(access, 9, None)


def test_finite_refuses_nan_and_infinities_with_a_warning_naming_id_and_field():
    rules, lines = _rules(FakeAccess({1: XM430}))
    assert rules.finite("goal", "position_deg", 1, 1.5) and rules.finite("goal", "position_deg", 1, 3)
    assert not rules.finite("goal", "position_deg", 1, math.nan)
    assert not rules.finite("goal", "current_ma", 1, -math.inf)
    assert lines == ["goal: ID 1 'position_deg' = nan refused (not a finite number)",
                     "goal: ID 1 'current_ma' = -inf refused (not a finite number)"]
    assert all_finite([1.0, 2.0]) and not all_finite([1.0, math.nan]) and not all_finite([1e308, 1e308])


def test_goal_position_clamped_to_the_position_limits_in_position_mode():
    access = FakeAccess({1: XM430}, values={"min_position_limit": {1: 1000}, "max_position_limit": {1: 3000}})
    rules, lines = _rules(access)
    assert rules.clamp("goal", "position_deg", 1, "goal_position", 200.0, 4000) == 3000
    assert rules.clamp("goal", "position_deg", 1, "goal_position", -100.0, 10) == 1000
    assert rules.clamp("goal", "position_deg", 1, "goal_position", 10.0, 2100) == 2100
    assert len(lines) == 2 and "ID 1 (XM430-W350) 'position_deg' = 200 is beyond the servo's limit: clamped to" in lines[0]


def test_multi_turn_goal_bounds_follow_the_family():
    access = FakeAccess({1: XM430, 2: PH54}, modes={1: "ex_position", 2: "ex_position"})
    rules, _ = _rules(access)
    assert rules.limits(1, "goal_position", access.model(1)) == (-1_048_575, 1_048_575)
    turns = round(256 * 360 / access.model(2).position_deg_per_pulse)
    assert rules.limits(2, "goal_position", access.model(2)) == (-turns, turns)


def test_magnitude_limits_and_profile_ranges():
    access = FakeAccess({1: XM430, 2: PH54}, values={"velocity_limit": {1: 200, 2: 2900}, "current_limit": {1: 1193}})
    rules, _ = _rules(access)
    assert rules.limits(1, "goal_velocity", access.model(1)) == (-200, 200)
    assert rules.limits(1, "goal_current", access.model(1)) == (-1193, 1193)
    # X profile registers: 0..32767 whatever Velocity Limit says; P: bounded by Velocity Limit
    assert rules.limits(1, "profile_velocity", access.model(1)) == (0, 32767)
    assert rules.limits(2, "profile_velocity", access.model(2)) == (0, 2900)


def test_clamp_rows_equals_clamp_of_each_row_with_and_without_the_table_bounds():
    access = FakeAccess({1: XM430, 2: XM430, 3: PH54},
                        values={"min_position_limit": {1: 1000, 2: 0, 3: -5000},
                                "max_position_limit": {1: 3000, 2: 4095, 3: 5000}})
    rows = [(1, 0.0), (2, 0.0), (3, 0.0)]
    pulses = np.array([3500, 2000, -9000], dtype=np.int64)
    at_once, at_once_lines = _rules(access, True)
    one_by_one, one_by_one_lines = _rules(access, False)
    assert at_once.clamp_rows("goal", "position_deg", "goal_position", rows, pulses) == [3000, 2000, -5000]
    assert one_by_one.clamp_rows("goal", "position_deg", "goal_position", rows, pulses) == [3000, 2000, -5000]
    assert at_once_lines == one_by_one_lines and len(at_once_lines) == 2


def test_to_pulses_refuses_an_item_the_model_lacks():
    rules, lines = _rules(FakeAccess({1: H54}))
    assert rules.to_pulses("goal", "pwm_percent", 1, "goal_pwm", 10.0) is None
    assert lines == ["goal: ID 1 (H54-200-S500-R) has no goal_pwm: 'pwm_percent' ignored"]


def test_limits_and_gains_are_clamped_to_the_model_s_e_manual_range_with_a_warning():
    """The servo would refuse a value beyond its e-Manual range (a Data Range Error): it is
    clamped before it is sent, the same range the set-up tool and the virtual bus hold to."""
    access = FakeAccess({1: XM430, 3: PH54})
    rules, lines = _rules(access)
    assert rules.limits(3, "velocity_limit", access.model(3)) == (0, 2900)      # PH54-200 page
    assert rules.limits(1, "position_p_gain", access.model(1)) == (0, 16383)    # X gains
    assert rules.to_pulses("limit", "velocity_limit_deg_s", 3, "velocity_limit", 1e6) == 2900
    assert rules.to_pulses("gain", "position_p_gain_pulse", 1, "position_p_gain", 20000) == 16383
    assert len(lines) == 2 and all("beyond the servo's limit: clamped to" in line for line in lines), lines
