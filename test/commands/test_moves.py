"""``commands.moves``: the torque and move jobs of the services and the action, advanced by the loop
after each step (``Book.on_step``) over an in-process ``ServoAccess``: how each ends and with which
message, what it writes, a later move preempting an earlier one, a servo that cannot move, a
cancel that holds the servos where they are, and a job the loop never got to answered anyway."""
import time

import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.moves import (
    CANCELED,
    DONE,
    ERROR,
    MAX_JOBS,
    PREEMPTED,
    REACHED,
    Book,
    MoveError,
    TorqueJob,
    new_move,
)
from dynamixel_handler.core.request_types import Answer, Outcome

from support.servo_access import FakeAccess

XM430 = 1020
VALUES = {"min_position_limit": {1: 1024, 2: 0}, "max_position_limit": {1: 3072, 2: 4095},
          "torque_enable": {1: 1, 2: 1}}


class Access(FakeAccess):
    """Torque on fails on the IDs in ``refuse`` (the servo did not answer)."""

    refuse: set[int] = set()

    def torque_on(self, dxl_id, what=""):
        if dxl_id in self.refuse:
            self.calls.append(("torque_on", dxl_id))
            return Answer(Outcome.FAILED, "no reply")
        return super().torque_on(dxl_id, what)


def _book(refuse=()):
    access = Access({1: XM430, 2: XM430}, values=VALUES)
    access.refuse = set(refuse)
    woken: list[int] = []
    commander = Commander(access)
    book = Book(access, commander, None, wake=lambda: woken.append(1))
    access.attach(commander)
    access.attach(book)
    return book, access, woken


def _move(book, ids, degs, wait=True, timeout_s=5.0):
    job = new_move(book, [(i, None) for i in ids], degs, velocity=0.0, tolerance_deg=1.0, timeout_s=timeout_s, wait=wait)
    book.add(job)
    return job


def _arrive(access, dxl_id):
    """The servo's present position is its goal."""
    access.table.set_value("present_position", dxl_id, access.pending.peek("goal_position")[dxl_id])


def test_a_torque_job_writes_each_servo_and_ends_done_waking_the_caller_once():
    book, access, woken = _book()
    job = TorqueJob([1, 2], True, time.monotonic() + 5.0)
    book.add(job)
    book.on_step()
    assert access.calls == [("torque_on", 1), ("torque_on", 2)]
    assert (job.outcome, job.message) == (DONE, "torque on: IDs [1, 2]") and woken == [1] and not book.jobs


def test_a_torque_job_names_the_servos_it_failed_on_and_refuses_servos_not_handled():
    book, access, _ = _book(refuse={2})
    failed = TorqueJob([1, 2], True, time.monotonic() + 5.0)
    book.add(failed)
    book.on_step()
    assert (failed.outcome, failed.message) == (ERROR, "torque on failed on IDs [2]: no reply")
    access.calls.clear()
    unknown = TorqueJob([1, 9], False, time.monotonic() + 5.0)
    book.add(unknown)
    book.on_step()
    assert (unknown.outcome, unknown.message) == (ERROR, "IDs [9] are not handled: nothing changed")
    assert access.calls == []


def test_a_move_without_waiting_ends_once_its_goals_are_written():
    book, access, _ = _book()
    job = _move(book, [1, 2], [10.0, -20.0], wait=False)
    book.on_step()
    assert job.outcome == DONE and job.message == "goals written"
    goals = access.pending.peek("goal_position")
    assert set(goals) == {1, 2} and job.move.goal_deg == pytest.approx([10.0, -20.0], abs=0.1)


def test_a_waiting_move_is_judged_each_loop_until_every_servo_is_within_tolerance():
    book, access, _ = _book()
    job = _move(book, [1, 2], [10.0, 20.0])
    book.on_step()
    assert job.state == "following" and not job.finished
    _arrive(access, 1)
    book.on_step()
    assert not job.finished
    _arrive(access, 2)
    book.on_step()
    assert job.outcome == REACHED and job.message == "reached within 1 deg"
    assert job.positions == pytest.approx([10.0, 20.0], abs=0.1)


def test_a_goal_clamped_to_the_servos_limits_is_noted_in_the_answer():
    book, _, _ = _book()
    job = _move(book, [1], [150.0], wait=False)  # ID 1 stops at 90 deg
    book.on_step()
    assert job.outcome == DONE
    assert job.message.startswith("goals written; ID 1: goal is 90.00 deg (servo), not 150.00 (clamped")


def test_a_later_move_preempts_an_earlier_one_on_a_shared_servo():
    book, access, _ = _book()
    unwritten = _move(book, [1], [10.0])
    later = _move(book, [1], [20.0])
    book.on_step()  # both ready in one step: only the later one is written
    assert unwritten.outcome == PREEMPTED and "nothing was written" in unwritten.message
    assert access.goals == [{"goal_position": {1: access.pending.peek("goal_position")[1]}}]
    newest = _move(book, [1], [30.0])
    book.on_step()
    assert later.outcome == PREEMPTED and later.message == "preempted by a later move of ID 1"
    assert not newest.finished


def test_a_move_of_a_servo_with_torque_off_is_refused_and_writes_nothing():
    book, access, _ = _book()
    access.table.set_value("torque_enable", 2, 0)
    job = _move(book, [1, 2], [0.0, 0.0])
    book.on_step()
    assert (job.outcome, job.message) == (ERROR, "torque is off on IDs [2]: enable it first (set_torque)")
    assert access.goals == []


def test_a_cancelled_move_holds_the_servos_where_they_are():
    book, access, _ = _book()
    job = _move(book, [1], [45.0])
    book.on_step()
    access.table.set_value("present_position", 1, 2048 + 100)
    job.cancel_requested = True
    book.on_step()
    assert job.outcome == CANCELED and access.goals[-1] == {"goal_position": {1: 2048 + 100}}


def test_a_job_the_loop_never_got_to_is_answered_at_its_time_and_too_many_are_refused():
    book, access, _ = _book()
    job = _move(book, [1], [0.0])
    book.expire(job, job.answer_by + 1.0)
    assert (job.outcome, job.message) == (ERROR, "the bus loop did not carry out 'move' in time: nothing was written")
    book.on_step()
    assert access.goals == []
    for _ in range(MAX_JOBS):
        book.jobs.append(job)
    with pytest.raises(MoveError, match=f"{MAX_JOBS} requests are waiting already: try again later"):
        _move(book, [2], [0.0])
