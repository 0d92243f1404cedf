"""``commands.fast_path.FastGoals``: which commands it takes, what it keeps, and its switches."""
import math

import numpy as np

from dynamixel_handler.commands import Commander, CommandPaths
from dynamixel_handler.commands.fast_path import FastGoals
from dynamixel_handler.commands.goal_bounds import TableBounds
from dynamixel_handler.commands.rules import Rules
from dynamixel_handler.control_table import PRO, X

from support.servo_access import FakeAccess, attached

XM430, H54 = 1020, 54024
VALUES = {"min_position_limit": {1: 0, 2: 0, 3: -100_000}, "max_position_limit": {1: 4095, 2: 4095, 3: 100_000}}


def _commander(paths=None, modes=None):
    access = FakeAccess({1: XM430, 2: XM430, 3: H54}, modes=modes, values=VALUES)
    return attached(Commander(access, paths)), access


def test_targets_are_checked_once_per_id_list_and_family_and_forgotten_when_the_servos_change():
    c, access = _commander()
    plan = c.fast.targets([1, 2], X)
    assert plan is not None and plan.ids == [1, 2]
    assert c.fast.targets([1, 2], X) is plan
    assert c.fast.targets([1, 2], None) is not plan
    for refused in ([1, 1], [1, 9], [1, 3], []):  # repeated, unknown, another family, none
        assert c.fast.targets(refused, X) is None, refused
    assert c.fast.targets([3], PRO) is not None
    access.table.add(4, access.model(1))
    assert c.fast.targets([1, 2], X) is not plan  # a new table version


def test_the_common_command_takes_the_fast_path_and_the_others_do_not():
    c, access = _commander(modes={2: "velocity"})
    assert c.fast.goals("x", [1], {"position_deg": [1.0]}, X, "position")
    assert not c.fast.goals("x", [1, 2], {"position_deg": [1.0, 2.0]}, X, "position")  # ID 2 in another mode
    assert not c.fast.goals("goal", [1], {"position_deg": [math.nan]})
    assert not c.fast.goals("goal", [1], {"position_deg": [1]})  # an int: checked one by one
    assert not c.fast.goals("x", [1], {"position_deg": [1.0], "rotation": [1.0]}, X, "position")
    # the old PRO's speed of a move depends on the model
    assert not c.fast.goals("pro", [3], {"position_deg": [0.0], "velocity_deg_s": [1.0]}, PRO, "position")
    assert access.goals == [{"goal_position": {1: 2048 + round(1.0 / (360 / 4096))}}]


def test_a_goal_outside_its_bounds_is_clamped_by_the_same_rule_in_plain_python_and_numpy():
    goals = []
    for small in (32, 0):
        c, access = _commander(CommandPaths(small=small))
        assert c.fast.goals("goal", [1, 2], {"position_deg": [400.0, 10.0]})
        goals.append(access.goals)
    assert goals[0] == goals[1] == [{"goal_position": {1: 4095, 2: 2048 + round(10.0 / (360 / 4096))}}]


def test_switched_off_it_takes_nothing():
    c, access = _commander(CommandPaths(targets=False))
    assert c.fast.targets([1], X) is None
    assert not c.fast.goals("goal", [1], {"position_deg": [1.0]})
    c.goal([1], {"position_deg": [1.0]})  # the per-servo path writes it
    assert access.goals == [{"goal_position": {1: 2048 + round(1.0 / (360 / 4096))}}]


def test_many_servos_are_converted_through_numpy_with_the_same_pulses():
    ids = list(range(1, 41))
    access = FakeAccess({i: XM430 for i in ids})
    values = np.linspace(-170.0, 170.0, len(ids)).tolist()
    for small in (32, 100):
        c = attached(Commander(access, CommandPaths(small=small)))
        assert c.fast.goals("goal", ids, {"position_deg": values})
    assert access.goals[0] == access.goals[1]


def test_built_on_its_own_it_hands_the_goals_it_takes_to_its_writer_and_leaves_the_rest_untouched():
    """``FastGoals`` with the real rules of the command side and a recorder for the writes it hands on."""
    access = FakeAccess({1: XM430, 2: XM430, 3: H54}, values=VALUES)
    lines: list[str] = []
    handed: list[tuple[str, dict]] = []
    fast = FastGoals(access, Rules(access, lines.append, TableBounds()), CommandPaths(),
                     lambda what, writes: handed.append((what, writes)))
    assert fast.goals("goal", [1, 2], {"position_deg": [0.0, 400.0]})
    assert handed == [("goal", {"goal_position": {1: 2048, 2: 4095}})]
    assert lines == ["ID 2 (XM430-W350) 'position_deg' = 400 is beyond the servo's limit: clamped to 179.912"]
    assert not fast.goals("goal", [1, 9], {"position_deg": [0.0, 0.0]})  # an unknown ID: the per-servo path
    assert len(handed) == 1 and access.goals == [] and access.calls == []
