"""``commands.move_checks``: a move request checked at arrival, and how a waiting move ends."""
import math

import pytest

from dynamixel_handler.commands.move_checks import (
    CANCELED,
    ERROR,
    REACHED,
    SILENT_S,
    TIMED_OUT,
    Move,
    MoveError,
    Watch,
    checked_positions,
    listed,
    targets_of,
)


def test_targets_by_id_and_the_refusals():
    assert targets_of(None, [3, 1], [], handled=4) == [(3, None), (1, None)]
    with pytest.raises(MoveError, match=r"IDs named more than once: 1 \(2 times\)"):
        targets_of(None, [1, 2, 1], [], handled=4)
    with pytest.raises(MoveError, match="3 servos named, 2 handled"):
        targets_of(None, [1, 2, 3], [], handled=2)


def test_positions_must_be_finite_and_one_per_servo():
    targets = [(1, None), (2, None)]
    assert checked_positions(targets, [1, 2.5], 0.0) == [1.0, 2.5]
    with pytest.raises(MoveError, match="1 positions for 2 servos"):
        checked_positions(targets, [1.0], 0.0)
    with pytest.raises(MoveError, match="positions of 2 are not finite numbers"):
        checked_positions(targets, [1.0, math.nan], 0.0)
    with pytest.raises(MoveError, match="velocity -1.0 must be a finite value >= 0"):
        checked_positions(targets, [1.0, 2.0], -1.0)


def test_listed_cuts_long_lists():
    assert listed([1, 2, 3]) == "1, 2, 3"
    assert listed(range(10_000), limit=12) == "0, 1, 2, 3 (9996 more)"


def _watch(deadline=10.0):
    return Watch(Move([(1, "elbow"), (2, None)], [0.0, 0.0], tolerance_deg=1.0, deadline=deadline))


def test_a_move_is_reached_within_tolerance_and_times_out_naming_the_far_servos():
    assert _watch().verdict([True, True], [0.5, 0.9], 1.0, lambda: False)[0] == REACHED
    watch = _watch(deadline=2.0)
    assert watch.verdict([True, True], [5.0, 0.5], 1.0, lambda: False) is None
    outcome, message = watch.verdict([True, True], [5.0, 0.5], 2.0, lambda: False)
    assert outcome == TIMED_OUT and message == "timed out: elbow 5.0 deg away"
    assert _watch().verdict([True, True], [5.0, 5.0], 1.0, lambda: True)[0] == CANCELED


def test_one_missed_read_does_not_end_a_move_a_silent_servo_does():
    watch = _watch()
    assert watch.verdict([True, False], [5.0, 5.0], 1.0, lambda: False) is None
    assert watch.verdict([True, False], [5.0, 5.0], 1.0 + SILENT_S / 2, lambda: False) is None
    assert watch.verdict([True, False], [5.0, 5.0], 1.0 + SILENT_S, lambda: False) == (ERROR, "ID 2 stopped answering")
    # a servo that answers again is no longer counted silent
    assert watch.verdict([True, True], [0.0, 0.0], 2.0, lambda: False)[0] == REACHED
