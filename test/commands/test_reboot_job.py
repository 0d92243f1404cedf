"""The reboot jobs (``commands.reboot_job``) in the Book over a ServoAccess stand-in: only the servos
in error are cleared (one ClearError each), each named with its outcome; none in error: nothing.
The servos named (``RebootServosJob``) rebooted one a step, after every one was checked: torque
on without consent or an ID not handled and none is rebooted; torque back on where it was on."""
from __future__ import annotations

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.move_checks import DONE, ERROR
from dynamixel_handler.commands.moves import Book
from dynamixel_handler.commands.reboot_job import TORQUE_REFUSAL, Rebooted, RebootJob, RebootServosJob
from dynamixel_handler.core.request_types import Answer, Outcome

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


class Booting(FakeAccess):
    """A stand-in whose reboot turns torque off, as a servo's does, and whose torque on turns it on."""

    def reboot(self, dxl_id, keep_turns=False):
        self.table.set_value("torque_enable", dxl_id, 0)
        return super().reboot(dxl_id, keep_turns)

    def torque_on(self, dxl_id, what=""):
        self.table.set_value("torque_enable", dxl_id, 1)
        return super().torque_on(dxl_id, what)


def _run_named(access: FakeAccess, ids: list[int], torque_off: bool, steps: int = 5) -> RebootServosJob:
    book = attached(Book(access, attached(Commander(access)), None))
    job = RebootServosJob(ids, torque_off, answer_by=1e12)
    book.add(job)
    for _ in range(steps):
        book.on_step()
    return job


def test_named_servos_are_rebooted_one_a_step_healthy_ones_too_torque_back_as_it_was():
    access = Booting({1: XM430, 2: XM430, 3: XM430}, values={"hardware_error_status": {1: 0, 2: 0, 3: 0},
                                                               "torque_enable": {1: 1, 2: 0, 3: 1}})
    book = attached(Book(access, attached(Commander(access)), None))
    job = RebootServosJob([2, 1], True, answer_by=1e12)
    book.add(job)
    book.on_step()  # the checks
    assert not [c for c in access.calls if c[0] == "reboot"]
    book.on_step()
    assert [c for c in access.calls if c[0] == "reboot"] == [("reboot", 2, "keep_turns")]
    book.on_step()
    assert job.outcome == DONE, job.message
    assert [c for c in access.calls if c[0] in ("reboot", "torque_on")] == [("reboot", 2, "keep_turns"), ("reboot", 1, "keep_turns"),
                                                                                 ("torque_on", 1)]
    assert job.results == [Rebooted(2, True, False), Rebooted(1, True, True)]
    assert job.message == "ID 2 (XM430-W350): rebooted, torque off; ID 1 (XM430-W350): rebooted, torque on"
    assert access.table.value("torque_enable", 3) == 1  # not named: untouched


def test_a_servo_holding_torque_without_consent_refuses_the_whole_request():
    access = Booting({1: XM430, 2: XM430}, values={"torque_enable": {1: 0, 2: 1}})
    job = _run_named(access, [1, 2], torque_off=False)
    assert job.outcome == ERROR and not [c for c in access.calls if c[0] == "reboot"]
    assert job.message == f"refused, nothing rebooted: ID 2: {TORQUE_REFUSAL}"
    assert [r.error for r in job.results] == ["not rebooted: another servo named was refused", TORQUE_REFUSAL]


def test_an_id_not_handled_refuses_the_request_and_a_torque_on_refused_is_named():
    access = Booting({1: XM430}, values={"torque_enable": {1: 0}})
    job = _run_named(access, [1, 9], torque_off=True)
    assert job.outcome == ERROR and job.message == "refused, nothing rebooted: ID 9: not handled by this node"

    class NoTorque(Booting):
        def torque_on(self, dxl_id, what=""):
            return Answer(Outcome.REFUSED, "the E-stop is engaged")

    access = NoTorque({1: XM430}, values={"torque_enable": {1: 1}})
    job = _run_named(access, [1], torque_off=True)
    assert job.outcome == ERROR and job.results == [Rebooted(1, True, False, "rebooted; torque stays off: the E-stop "
                                                                            "is engaged")]
