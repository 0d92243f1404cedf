"""``commands.goal_bounds``: goal position bounds as table maths, per servo and for a whole table."""
import numpy as np

from dynamixel_handler.commands.goal_bounds import TableBounds, Targets, goal_position_bounds, goal_position_limits

from support.servo_access import FakeAccess

XM430, PH54, H54 = 1020, 2020, 54024
LIMITS = {"min_position_limit": {1: 1000, 2: -9000, 3: 0, 4: 5}, "max_position_limit": {1: 3000, 2: 9000, 3: 4095, 4: 4}}


def _access(modes):
    return FakeAccess({1: XM430, 2: PH54, 3: H54, 4: XM430}, modes=modes, values=LIMITS)


def test_the_table_bounds_equal_each_servos_bounds_in_every_mode():
    for mode in ("position", "ex_position", "velocity", "current"):
        access = _access({i: mode for i in (1, 2, 3, 4)})
        lo, hi, ok = TableBounds().of_table(access.table)
        assert ok.all()
        each = [goal_position_limits(access, i, access.model(i)) for i in (1, 2, 3, 4)]
        assert list(zip(lo.tolist(), hi.tolist())) == each, mode
        assert goal_position_bounds(access.table, [1, 2, 3, 4]) is not None


def test_position_mode_uses_valid_limits_else_the_family_range():
    access = _access({})
    assert goal_position_limits(access, 1, access.model(1)) == (1000, 3000)
    # ID 4's limits are crossed (5 > 4): the X register range
    spec = access.model(4).item("goal_position")
    assert goal_position_limits(access, 4, access.model(4)) == (spec.min_raw, spec.max_raw)


def test_within_says_which_goals_are_inside_and_none_when_the_table_lacks_a_value():
    access = _access({})
    bounds = TableBounds()
    inside = bounds.within(access.table, [1, 3], np.array([3001, 100]))
    assert inside is not None and inside.tolist() == [False, True]
    assert bounds.within(access.table, [1, 99], np.array([0, 0])) is None  # an ID not in the table
    assert TableBounds(enabled=False).within(access.table, [1], np.array([2000])) is None
    lacking = FakeAccess({1: XM430})  # position mode, no limits read
    assert TableBounds().within(lacking.table, [1], np.array([2000])) is None


def test_table_bounds_are_kept_until_an_array_they_come_from_is_replaced():
    access = _access({})
    bounds = TableBounds()
    first = bounds.of_table(access.table)
    assert bounds.of_table(access.table) is first
    access.table.set_value("max_position_limit", 1, 2500)
    second = bounds.of_table(access.table)
    assert second is not first and second[1][0] == 2500


def test_targets_mode_items_and_bounds():
    access = _access({1: "ex_position", 4: "ex_position"})
    plan = Targets(access.table, (4, 1))
    assert plan.ids == [4, 1] and plan.mode() == "ex_position"
    assert plan.has("goal_position") and plan.has("goal_current")
    assert plan.bounds(TableBounds().of_table(access.table)) == ([-1_048_575] * 2, [1_048_575] * 2)
    assert plan.bounds(None) is None
    access.table.set_value("operating_mode", 1, 3)
    assert plan.mode() is None  # the two now differ
    assert not Targets(access.table, (3,)).has("goal_pwm")  # old PRO: no PWM
