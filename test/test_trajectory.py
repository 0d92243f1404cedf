"""Trajectory interpolation and judging (ROS-free): the segments meet the points' positions,
velocities and accelerations; bad points are refused with the reason; tolerances decide the outcome."""
from __future__ import annotations

import numpy as np
import pytest

from dynamixel_handler.commands.trajectory import (
    GOAL_VIOLATED,
    PATH_VIOLATED,
    RUNNING,
    SUCCEEDED,
    Tolerances,
    Trajectory,
    TrajectoryError,
    TrajectoryRun,
    make_points,
)


@pytest.mark.parametrize("with_vel,with_acc", [(False, False), (True, False), (True, True)])
def test_segments_meet_every_point(with_vel, with_acc):
    times = [0.5, 1.2, 2.0]
    pos = [[0.4, -1.0], [1.0, 0.3], [0.2, 0.2]]
    vel = [[0.5, -0.2], [-0.3, 0.8], [0.0, 0.0]] if with_vel else [[], [], []]
    acc = [[1.0, 0.0], [-2.0, 0.5], [0.0, 0.0]] if with_acc else [[], [], []]
    traj = Trajectory(make_points(2, times, pos, vel, acc), start=np.array([0.0, 0.0]))
    for k, t in enumerate(times):
        for s in (t - 1e-7, t + 1e-7):
            got = traj.sample(s)
            assert got.positions == pytest.approx(pos[k], abs=1e-5)
            if with_vel:
                assert got.velocities == pytest.approx(vel[k], abs=1e-4)
            if with_acc:
                assert got.accelerations == pytest.approx(acc[k], abs=1e-2)
    assert traj.sample(0.0).positions == pytest.approx([0.0, 0.0])  # from where the joints were
    assert traj.sample(10.0).positions == pytest.approx(pos[-1])   # and holds the last point


def test_bad_points_are_refused_with_the_reason():
    with pytest.raises(TrajectoryError, match="no points"):
        make_points(1, [], [], [], [])
    with pytest.raises(TrajectoryError, match="point 1: time_from_start 1 s does not come after point 0"):
        make_points(1, [1.0, 1.0], [[0.0], [1.0]], [[], []], [[], []])
    with pytest.raises(TrajectoryError, match="point 0: 1 positions for 2 joints"):
        make_points(2, [1.0], [[0.0]], [[]], [[]])
    with pytest.raises(TrajectoryError, match="not all finite"):
        make_points(1, [1.0], [[float("nan")]], [[]], [[]])
    with pytest.raises(TrajectoryError, match="accelerations without velocities"):
        make_points(1, [1.0], [[0.0]], [[]], [[1.0]])


def test_tolerances_decide_the_outcome():
    traj = Trajectory(make_points(1, [1.0], [[1.0]], [[]], [[]]), start=np.array([0.0]))
    run = TrajectoryRun(["j"], traj, Tolerances(path=np.array([0.1]), goal=np.array([0.02]), goal_time=0.5))
    assert run.judge(0.5, np.array([0.45])).outcome == RUNNING
    verdict = run.judge(0.5, np.array([0.3]))
    assert verdict.outcome == PATH_VIOLATED and "joint j is 0.2000 rad off the path" in verdict.message
    assert run.judge(1.2, np.array([0.9])).outcome == RUNNING        # late, but within goal_time
    assert run.judge(1.6, np.array([0.9])).outcome == GOAL_VIOLATED
    assert run.judge(1.6, np.array([0.99])).outcome == SUCCEEDED
    unchecked = TrajectoryRun(["j"], traj, Tolerances(path=np.array([0.0]), goal=np.array([0.0]), goal_time=0.0))
    assert unchecked.judge(0.5, np.array([-5.0])).outcome == RUNNING
    assert unchecked.judge(1.0, np.array([-5.0])).outcome == SUCCEEDED
