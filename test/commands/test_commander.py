"""``commands.Commander`` against an in-process ``ServoAccess``: what a command hands to the core,
what it refuses, and that the fast path and the per-servo path hand over the same."""
import math

import pytest

from dynamixel_handler.commands import Commander, CommandPaths

from support.servo_access import FakeAccess, attached, warnings_of

XM430, XL430, PH54, H54 = 1020, 1060, 2020, 54024
SERVOS = {1: XM430, 2: XM430, 3: PH54, 4: H54, 5: XL430}
VALUES = {"min_position_limit": {1: 1000, 2: 0, 3: -100_000, 4: -100_000, 5: 0},
          "max_position_limit": {1: 3000, 2: 4095, 3: 100_000, 4: 100_000, 5: 4095},
          "velocity_limit": {1: 200, 2: 200, 3: 2900, 4: 8000, 5: 200},
          "current_limit": {1: 1193, 2: 1193, 3: 22740, 4: 2000}}
PLAIN = CommandPaths(bounds=False, targets=False)


def _commander(paths=None, modes=None):
    access = FakeAccess(SERVOS, modes=modes, values=VALUES)
    lines = warnings_of(access)
    return attached(Commander(access, paths)), access, lines


def _both(command, modes=None):
    """(goals, other requests, warnings) of ``command`` with the fast paths and without."""
    out = []
    for paths in (None, PLAIN):
        c, access, lines = _commander(paths, modes)
        command(c)
        out.append((access.goals, [call for call in access.calls if call[0] != "cancel_deferred"], lines))
    return out


@pytest.mark.parametrize("command", [
    lambda c: c.control("X", "position_control", [1, 2], {"position_deg": [10.0, 20.0]}),
    lambda c: c.control("X", "position_control", [1, 2], {"position_deg": [170.0, -190.0]}),  # beyond: clamped
    lambda c: c.goal([1, 3, 4], {"position_deg": [1e9, -1e9, 45.0], "velocity_deg_s": [1e4, 5.0, -1e4]}),
    lambda c: c.control("P", "position_control", [3], {"position_deg": [-500.0], "profile_vel_deg_s": [1e6]}),
    lambda c: c.goal([1, 2], {"profile_vel_deg_s": [1e9, 1.0], "current_ma": [1e5, -1e5]}),
], ids=["inside", "clamped", "goal mixed", "P profile", "X profile and current"])
def test_the_fast_path_and_the_per_servo_path_hand_over_the_same_pulses_and_warnings(command):
    fast, plain = _both(command)
    assert fast == plain
    assert fast[0]  # something was written


def test_a_goal_beyond_the_position_limits_is_clamped_with_one_warning():
    c, access, lines = _commander()
    c.control("X", "position_control", [1], {"position_deg": [170.0]})
    assert access.goals == [{"goal_position": {1: 3000}}]
    assert len(lines) == 1 and "ID 1 (XM430-W350) 'position_deg' = 170 is beyond the servo's limit" in lines[0]


def test_unknown_ids_are_refused_and_the_others_written():
    c, access, lines = _commander()
    c.goal([1, 77, 2], {"position_deg": [0.0, 0.0, 0.0]})
    assert access.goals == [{"goal_position": {1: 2048, 2: 2048}}]
    assert lines == ["goal: ID 77 is not handled: ignored"]


def test_nan_is_refused_for_its_servo_only():
    c, access, lines = _commander()
    c.goal([1, 2], {"position_deg": [math.nan, 0.0]})
    assert access.goals == [{"goal_position": {2: 2048}}]
    assert lines == ["goal: ID 1 'position_deg' = nan refused (not a finite number)"]


def test_ids_of_another_family_are_refused():
    c, access, lines = _commander()
    c.control("P", "position_control", [1, 3], {"position_deg": [0.0, 0.0]})
    assert access.goals == [{"goal_position": {3: 0}}]
    assert lines == ["p/position_control: ID 1 is XM430-W350 (series X), not P: ignored"]


def test_a_mode_the_servo_has_not_is_refused_and_nothing_written():
    c, access, lines = _commander()
    c.control("X", "current_control", [5], {"current_ma": [10.0]})  # XL430: no current sensor
    c.control("PRO", "velocity_control", [4], {"velocity_deg_s": [1.0]})
    assert access.goals == [{"goal_velocity": {4: round(1.0 / access.model(4).velocity_deg_s_per_pulse)}}]
    assert ("change_mode", 5, "current") not in access.calls
    assert lines[0] == "x/current_control: ID 5 (XL430-W250) has no current sensor, so no 'current' mode: ignored"
    c.control("P", "current_base_position_control", [3], {"position_deg": [0.0]})
    assert "has no 'cur_position' mode: ignored" in lines[-1]


def test_a_servo_in_another_mode_is_switched_before_its_goal():
    c, access, _ = _commander(modes={1: "velocity"})
    c.control("X", "position_control", [1], {"position_deg": [0.0]})
    assert ("change_mode", 1, "position") in access.calls
    assert access.goals == [{"goal_position": {1: 2048}}]


def test_the_speed_of_a_pro_move_is_its_goal_velocity():
    c, access, _ = _commander()
    c.control("PRO", "position_control", [4], {"position_deg": [0.0], "velocity_deg_s": [6.0]})
    assert set(access.goals[0]) == {"goal_position", "goal_velocity"}
    c.control("X", "position_control", [1], {"position_deg": [0.0], "profile_vel_deg_s": [6.0]})
    assert set(access.goals[1]) == {"goal_position", "profile_velocity"}


def test_rotation_is_bounded_to_256_turns_and_refused_with_its_position_when_not_finite():
    c, access, lines = _commander(modes={2: "ex_position"})
    c.control("X", "extended_position_control", [2], {"rotation": [300.0]})
    assert access.goals == [{"goal_position": {2: 1_048_575}}]
    c.control("X", "extended_position_control", [2], {"position_deg": [0.0], "rotation": [math.inf]})
    assert len(access.goals) == 1 and "refused (not a finite number), and with it the position goal" in lines[-1]
