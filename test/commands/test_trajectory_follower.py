"""``commands.trajectory.Follower``, the loop hook that follows a joint trajectory, over the joint
goals of an in-process ``ServoAccess``: it starts from the positions read, commands the positions
of one period ahead, ends the trajectory as the tolerances say (holding the joints where a
failure leaves them), gives way to a newer one, and says why it cannot start. (The interpolation
and the verdicts alone: test/test_trajectory.py.)"""
import logging
import math
import time

import numpy as np
import pytest

from dynamixel_handler import units
from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.joint_goals import JointGoals
from dynamixel_handler.commands.trajectory import (
    ABORTED,
    PATH_VIOLATED,
    PREEMPTED,
    SUCCEEDED,
    Follower,
    Job,
    Tolerances,
    make_points,
)
from dynamixel_handler.core.state import StepReport
from dynamixel_handler.joints import JointMap

from support.servo_access import FakeAccess, attached

XM430 = 1020
PERIOD_S = 0.01
MAPPING = JointMap.simple(("pan",), (1,), (1,), (0.0,))


def _follower(present_pulses: int | None = 2048):
    values = {"min_position_limit": {1: 0}, "max_position_limit": {1: 4095}, "present_velocity": {1: 0}}
    if present_pulses is not None:
        values["present_position"] = {1: present_pulses}
    access = FakeAccess({1: XM430}, values=values)
    lines: list[str] = []
    log = logging.getLogger(f"test_trajectory_follower_{id(access)}")
    log.propagate = False
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    return Follower(attached(JointGoals(attached(Commander(access)), MAPPING)), PERIOD_S, log), access, lines


def _job(to_rad=1.0, seconds=1.0, started_ago=0.5, path=0.0, goal=0.01):
    return Job("trajectory", ["pan"], make_points(1, [seconds], [[to_rad]], [[]], [[]]),
               Tolerances(path=np.array([path]), goal=np.array([goal]), goal_time=0.2), time.time() - started_ago)


def _read(follower):
    follower(StepReport(loop=1, stamp=time.time(), present={"position"}))


def _goal_rad(access):
    pulses = access.goals[-1]["goal_position"][1]
    return float(units.pulse_to_unit([access.model(1)], "goal_position", [pulses])[0]) / (180.0 / math.pi)


def test_it_starts_from_the_positions_read_and_commands_the_position_of_one_period_ahead():
    follower, access, lines = _follower()
    job = _job(to_rad=1.0, seconds=1.0, started_ago=0.5)
    follower.start(job)
    _read(follower)
    # a straight line from 0 rad (where the joint was) to 1 rad in 1 s, half-way through: 0.5 rad and a period
    assert _goal_rad(access) == pytest.approx(0.5 + PERIOD_S, abs=0.05)
    assert job.run is not None and follower.active is job and not job.done.is_set() and lines == []


def test_a_trajectory_whose_joints_reach_the_goal_succeeds_without_a_line():
    follower, access, lines = _follower(present_pulses=2048 + 512)  # 45 deg: pi/4 rad
    job = _job(to_rad=math.pi / 4, seconds=0.1, started_ago=0.5)
    follower.start(job)
    _read(follower)
    assert job.outcome == SUCCEEDED and job.done.is_set() and follower.active is None
    assert lines == [] and access.goals == []  # nothing held, nothing more commanded


def test_a_joint_off_the_path_ends_it_held_where_it_is_with_a_warning():
    follower, access, lines = _follower()
    job = _job(to_rad=1.0, seconds=1.0, started_ago=0.5, path=0.1)
    follower.start(job)
    _read(follower)  # half-way through and the joint has not left 0 rad: 0.5 rad off the path
    assert job.outcome == PATH_VIOLATED and job.done.is_set()
    assert lines == [f"trajectory: {job.message}"] and "joint pan is" in job.message
    assert access.goals[-1] == {"goal_position": {1: 2048}}  # held where it is


def test_a_newer_trajectory_preempts_the_running_one_which_keeps_its_goals():
    follower, access, _ = _follower()
    first, second = _job(), _job(to_rad=-1.0)
    follower.start(first)
    _read(follower)
    written = len(access.goals)
    assert follower.start(second) is first
    assert first.outcome == PREEMPTED and first.message == "preempted by a newer trajectory" and first.done.is_set()
    assert len(access.goals) == written and follower.active is second


def test_a_stopped_trajectory_holds_its_joints_and_one_without_a_position_to_start_from_is_aborted():
    follower, access, _ = _follower()
    job = _job()
    follower.start(job)
    follower.stop(job, "cancelled", "cancelled by the client")
    assert job.outcome == "cancelled" and access.goals == [{"goal_position": {1: 2048}}]
    follower, access, lines = _follower(present_pulses=None)  # the joint's position was never read
    job = _job()
    follower.start(job)
    _read(follower)
    assert job.outcome == ABORTED and job.message == "no present position of ['pan'] to start from"
    assert lines == ["trajectory: no present position of ['pan'] to start from"] and access.goals == []


def test_a_vanished_device_ends_the_trajectory_at_the_next_loop_without_holding():
    follower, access, _ = _follower()
    job = _job()
    follower.start(job)
    _read(follower)
    lost = access.figures()
    access.figures = lambda: type(lost)(**{**lost.__dict__, "device_lost": True, "device_lost_since": time.time()})
    written = len(access.goals)
    _read(follower)
    assert job.outcome == ABORTED and "is gone" in job.message and len(access.goals) == written
