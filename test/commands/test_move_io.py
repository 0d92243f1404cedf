"""``commands.move_io``: a move's goals per family and mode through the Commander, and the goals it
reports back."""
import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.move_checks import MoveError
from dynamixel_handler.commands.move_io import MoveIO

from support.servo_access import FakeAccess, attached

XM430, PH54, H54 = 1020, 2020, 54024


def _io(modes=None):
    access = FakeAccess({1: XM430, 2: XM430, 3: PH54, 4: H54}, modes=modes)
    return MoveIO(access, attached(Commander(access)), None), access


def test_the_speed_of_a_move_goes_to_each_familys_item():
    io, access = _io(modes={2: "ex_position"})
    io._command([1, 2, 3, 4], [10.0, 20.0, 30.0, 40.0], velocity=6.0)
    by_item: dict[str, set[int]] = {}
    for goals in access.goals:
        for item, values in goals.items():
            by_item.setdefault(item, set()).update(values)
    assert by_item["goal_position"] == {1, 2, 3, 4}
    # X and P: the profile velocity; the old PRO (no profile): its goal velocity; a servo in
    # extended position mode keeps its mode and takes the profile velocity with its goal
    assert by_item["profile_velocity"] == {1, 2, 3} and by_item["goal_velocity"] == {4}
    assert not any(call[0] == "change_mode" for call in access.calls)


def test_without_a_velocity_only_positions_are_written():
    io, access = _io()
    io._command([1, 4], [0.0, 0.0], velocity=0.0)
    assert all(set(goals) == {"goal_position"} for goals in access.goals)


def test_the_goals_reported_are_those_waiting_for_the_write():
    io, access = _io()
    io._command([1], [90.0], velocity=0.0)
    assert io._goals([1]) == [pytest.approx(90.0, abs=0.1)]


def test_servos_not_handled_or_silent_are_refused():
    io, access = _io()
    with pytest.raises(MoveError, match=r"IDs \[9\] are not handled"):
        io._refuse_unready([1, 9])
    access.table.ping[access.table.index[2]] = False
    with pytest.raises(MoveError, match=r"IDs \[2\] do not answer"):
        io._refuse_unready([1, 2])
