"""The reboot job (``commands.reboot_job``) in the Book over a ServoAccess stand-in: only the servos
in error are cleared (one ClearError each), each named with its outcome; none in error: nothing."""
from __future__ import annotations

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.move_checks import DONE, ERROR
from dynamixel_handler.commands.moves import Book
from dynamixel_handler.commands.reboot_job import RebootJob

from support.fake_bus import XM430
from support.servo_access import FakeAccess, attached


def _run(access: FakeAccess) -> RebootJob:
    book = attached(Book(access, attached(Commander(access)), None))
    job = RebootJob(answer_by=1e12)
    book.add(job)
    book.on_step()
    return job


def test_none_in_error_nothing_is_touched():
    access = FakeAccess({1: XM430, 2: XM430}, values={"hardware_error_status": {1: 0, 2: 0}, "torque_enable": {1: 1, 2: 1}})
    job = _run(access)
    assert job.outcome == DONE and job.message == "no servo has a hardware error: none rebooted"
    assert not [c for c in access.calls if c[0] == "clear_error"]


def test_only_the_servo_in_error_is_cleared_and_its_outcome_named():
    access = FakeAccess({1: XM430, 2: XM430}, values={"hardware_error_status": {1: 0, 2: 0x20}, "torque_enable": {1: 1, 2: 1}})
    job = _run(access)  # the stand-in clears nothing: the error read again is still there
    assert [c for c in access.calls if c[0] == "clear_error"] == [("clear_error", 2, True)]
    assert job.outcome == ERROR and job.message == "ID 2 (XM430-W350): rebooted, the error is still there (0x20)"


class Rebooting(FakeAccess):
    """A stand-in whose error clear works: the servo's error reads 0 afterwards."""

    def clear_error(self, dxl_id, keep_rotation, what=""):
        answer = super().clear_error(dxl_id, keep_rotation, what)
        self.table.set_value("hardware_error_status", dxl_id, 0)
        return answer


def test_a_servo_whose_error_is_gone_is_named_with_its_torque():
    access = Rebooting({1: XM430, 3: XM430}, values={"hardware_error_status": {1: 0x20, 3: 0x04},
                                                       "torque_enable": {1: 1, 3: 0}})
    job = _run(access)
    assert job.outcome == DONE, job.message
    assert job.message == ("ID 1 (XM430-W350): rebooted, error gone, torque on; "
                           "ID 3 (XM430-W350): rebooted, error gone, torque off")
