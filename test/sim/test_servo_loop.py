"""The virtual servo's position loop (``sim/servo_loop.py``): the shaft follows the profile as the
Position P, I and D Gains say. Through the real dynamixel_sdk on a virtual bus, on a hand-advanced
clock (no host timing in the assertions)."""

import math

import pytest
from dynamixel_sdk import COMM_SUCCESS

from dynamixel_handler.sim.motion import Command, Motor
from dynamixel_handler.sim.servo_loop import ServoLoop

from support.clock import HandClock

XM430, XM430_STEP = 1020, 512  # a 45 deg step
GOAL, PRESENT, TRAJECTORY, P_GAIN, I_GAIN, D_GAIN, PWM_LIMIT = 116, 132, 140, 84, 82, 80, 36


@pytest.fixture
def step(make_bus, make_sdk):
    """step(p, i, d) -> present positions every 5 ms for 1.5 s after a 45 deg goal step
    (factory profiles of the virtual servo: no profile, the shaft's top speed caps the move)."""

    def run(p=800, i=0, d=0, *, pwm_limit=None):
        clock = HandClock(100.0)
        bus = make_bus({1: XM430}, clock=clock)
        port, ph = make_sdk(bus.path)
        for address, value in ((P_GAIN, p), (I_GAIN, i), (D_GAIN, d)):
            assert ph.write2ByteTxRx(port, 1, address, value)[:2] == (COMM_SUCCESS, 0)
        if pwm_limit is not None:
            assert ph.write2ByteTxRx(port, 1, PWM_LIMIT, pwm_limit)[:2] == (COMM_SUCCESS, 0)
        assert ph.write1ByteTxRx(port, 1, 64, 1)[:2] == (COMM_SUCCESS, 0)
        start = ph.read4ByteTxRx(port, 1, PRESENT)[0]
        assert ph.write4ByteTxRx(port, 1, GOAL, start + XM430_STEP)[:2] == (COMM_SUCCESS, 0)
        trace = []
        for _ in range(300):
            clock.t += 0.005
            value, result, _error = ph.read4ByteTxRx(port, 1, PRESENT)
            assert result == COMM_SUCCESS
            trace.append(value - start)
        return trace

    return run


def _t90(trace):
    return next(n for n, x in enumerate(trace) if x >= 0.9 * XM430_STEP)


def _overshoot(trace):
    return max(trace) - XM430_STEP


def test_factory_gains_reach_the_goal_with_little_overshoot(step):
    trace = step()
    assert trace[-1] == XM430_STEP
    assert _overshoot(trace) <= 0.03 * XM430_STEP
    assert _t90(trace) * 0.005 < 0.5  # the same order as the shaft at top speed (0.16 s)


def test_high_p_without_d_overshoots_more_than_factory(step):
    factory, stiff = step(), step(p=3200)
    assert _overshoot(stiff) > _overshoot(factory) + 5
    assert stiff[-1] == XM430_STEP


def test_d_damps_what_p_overshoots(step):
    stiff, damped = step(p=1600), step(p=1600, d=4000)
    assert _overshoot(damped) < _overshoot(stiff)
    assert _t90(damped) <= _t90(step())  # and it gets there no later than the factory gains


def test_low_p_is_slower(step):
    factory, soft = step(), step(p=200)
    assert _t90(soft) > 2 * _t90(factory)


def test_the_pwm_limit_slows_the_shaft(step):
    assert _t90(step(pwm_limit=300)) > 2 * _t90(step())


def test_the_profile_leads_the_shaft(make_bus, make_sdk):
    """Position Trajectory reads the profile; present position follows it, behind while it moves."""
    clock = HandClock(100.0)
    bus = make_bus({1: XM430}, clock=clock)
    port, ph = make_sdk(bus.path)
    ph.write1ByteTxRx(port, 1, 64, 1)
    start = ph.read4ByteTxRx(port, 1, PRESENT)[0]
    ph.write4ByteTxRx(port, 1, GOAL, start + 2000)
    clock.t += 0.1
    ref, present = ph.read4ByteTxRx(port, 1, TRAJECTORY)[0], ph.read4ByteTxRx(port, 1, PRESENT)[0]
    assert start < present < ref < start + 2000
    clock.t += 2.0
    assert ph.read4ByteTxRx(port, 1, TRAJECTORY)[0] == ph.read4ByteTxRx(port, 1, PRESENT)[0] == start + 2000


@pytest.mark.parametrize("p, i, d", [(16383, 0, 0), (0, 16383, 0), (16383, 16383, 16383), (1, 0, 16383),
                                     (1_000_000, 1_000_000, 1_000_000)])
def test_every_gain_stays_bounded(p, i, d):
    """Extreme gains (beyond any model's range too) give a bounded, finite shaft, however long."""
    v_top = 3127.0
    motor = Motor(0.0)
    cmd = Command(True, 0.0, 512.0, v_top, math.inf, loop=ServoLoop.from_gains(p / 800, i / 800, d / 800, v_top))
    for _ in range(2000):
        motor.advance(0.005, cmd)
        assert math.isfinite(motor.p) and abs(motor.v) <= v_top * 1.0001
        assert -2000.0 < motor.p < 3000.0


def test_the_same_gains_give_the_same_trace(step):
    assert step(p=1600, d=400) == step(p=1600, d=400)
