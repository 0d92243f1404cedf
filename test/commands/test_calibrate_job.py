"""The calibration job (``commands.calibrate_job``) in the Book over a ServoAccess stand-in: the
joint map replaced between two steps so that the measured joint reads its measurement, nothing
written to a servo; refused (the map untouched) while a trajectory runs on a named joint or when a
named joint's servo was never read."""
from __future__ import annotations

import logging
import math
import time

import numpy as np
import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.calibrate_job import CalibrateJob
from dynamixel_handler.commands.joint_goals import JointGoals
from dynamixel_handler.commands.move_checks import DONE, ERROR
from dynamixel_handler.commands.moves import Book
from dynamixel_handler.commands.trajectory import Follower, Job, Tolerances, make_points
from dynamixel_handler.joints import JointMap, LiveJoints, read_joints
from dynamixel_handler.joints.calibration import Calibration

from support.fake_bus import XM430
from support.servo_access import FakeAccess, attached

MAPPING = JointMap.simple(("pan", "tilt"), (1, 2), (1, -1), (0.0, 10.0))


def _parts(values):
    access = FakeAccess({1: XM430, 2: XM430}, values=values)
    joints = LiveJoints(MAPPING)
    commander = attached(Commander(access))
    follower = Follower(attached(JointGoals(commander, joints)), 0.01, logging.getLogger("test_calibrate_job"))
    return access, joints, attached(Book(access, commander, joints)), follower


def _run(book, job):
    book.add(job)
    book.on_step()
    return job


PRESENT = {"present_position": {1: 2048 + 512, 2: 2048}}  # pan at 45 deg, tilt's servo at 0 deg


def test_the_measured_joint_reads_its_measurement_from_the_next_step_and_nothing_is_written():
    access, joints, book, follower = _parts(PRESENT)
    job = _run(book, CalibrateJob(Calibration(("pan",), (0.5,)), joints, follower, answer_by=1e12))
    assert job.outcome == DONE and job.message.startswith("pan: offset 0 -> ")
    reading = read_joints(joints.map, access.table)
    assert dict(zip(reading.names, reading.position_rad.tolist())) == pytest.approx({"pan": 0.5, "tilt": math.radians(10.0)})
    assert job.positions == pytest.approx([0.5 - math.pi / 4], abs=1e-3)
    assert access.goals == [] and access.calls == []
    assert book.mapping is joints.map  # the Book's moves speak the new offsets too


def test_a_joint_whose_servo_was_never_read_is_refused_and_the_map_kept():
    access, joints, book, follower = _parts({"present_position": {1: 2048}})
    job = _run(book, CalibrateJob(Calibration(("pan", "tilt"), (0.1, 0.2)), joints, follower, answer_by=1e12))
    assert job.outcome == ERROR and "tilt: no present position of servo(s) [2] read" in job.message
    assert joints.map is MAPPING


def test_a_joint_with_a_running_trajectory_is_refused():
    access, joints, book, follower = _parts(PRESENT)
    points = make_points(1, [10.0], [[1.0]], [[]], [[]])
    follower.start(Job("trajectory", ["pan"], points, Tolerances(path=np.array([0.0]), goal=np.array([0.01]),
                                                                  goal_time=0.2), time.time()))
    job = _run(book, CalibrateJob(Calibration(("tilt", "pan"), (0.0, 0.0)), joints, follower, answer_by=1e12))
    assert job.outcome == ERROR and "a trajectory runs on pan" in job.message
    assert joints.map is MAPPING
