"""Motion behaviour a controller notices, on a hand-advanced clock (no timing in assertions)."""

import pytest
from dynamixel_sdk import COMM_SUCCESS

from dynamixel_handler.protocol import servo as p

XM430, XM540, PH54 = 1020, 1120, 2020


@pytest.fixture
def rig(make_bus, make_sdk, manual_clock):
    clock = manual_clock
    bus = make_bus({1: XM430, 2: XM540, 3: PH54}, clock=clock)
    port, ph = make_sdk(bus.path)

    def w(sid, address, value, size=4):
        fn = {1: ph.write1ByteTxRx, 2: ph.write2ByteTxRx, 4: ph.write4ByteTxRx}[size]
        return fn(port, sid, address, value)

    def r(sid, address, size=4, signed=True):
        fn = {1: ph.read1ByteTxRx, 2: ph.read2ByteTxRx, 4: ph.read4ByteTxRx}[size]
        value, result, error = fn(port, sid, address)
        assert result == COMM_SUCCESS
        if signed and value >= 1 << (8 * size - 1):
            value -= 1 << (8 * size)
        return value

    return bus, clock, w, r


def test_position_goal_is_reached_at_profile_velocity(rig):
    bus, clock, w, r = rig
    assert w(1, 112, 50) == (COMM_SUCCESS, 0)  # profile velocity 50 * 0.229 rpm
    assert w(1, 108, 100) == (COMM_SUCCESS, 0)  # profile acceleration
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    start = r(1, 132)
    assert w(1, 116, start + 1500) == (COMM_SUCCESS, 0)
    clock.advance(0.5)
    assert r(1, 128) == 50  # cruising at the profile velocity
    assert r(1, 122, 1) == 1
    assert r(1, 123, 1) & 0x32 == 0x32  # profile ongoing, trapezoidal
    pulses_per_s = 50 * 0.229 * 360 / 60 / (360 / 4096)
    ramp = pulses_per_s / (100 * 214.577 * 360 / 3600 / (360 / 4096))
    expected = start + pulses_per_s * (0.5 - ramp / 2)
    assert abs(r(1, 140) - expected) < 3  # the profile: Position Trajectory
    lag = pulses_per_s / 20.0  # the factory position loop (K = 20/s) follows a ramp this far behind
    assert abs(r(1, 132) - (expected - lag)) < 3
    clock.advance(2.0)
    assert r(1, 132) == start + 1500
    assert r(1, 128) == 0 and r(1, 122, 1) == 0
    assert r(1, 123, 1) & 0x01  # in position


def test_position_limits_apply_in_position_mode(rig):
    bus, clock, w, r = rig
    assert w(1, 48, 3000) == (COMM_SUCCESS, 0)
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 116, 3500) == (COMM_SUCCESS, p.ERR_DATA_LIMIT)
    assert w(1, 116, 2900) == (COMM_SUCCESS, 0)
    clock.advance(5)
    assert r(1, 132) == 2900


def test_extended_mode_keeps_turns_and_reboot_loses_them(rig):
    bus, clock, w, r = rig
    assert w(1, 11, 4, 1) == (COMM_SUCCESS, 0)
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    target = 2048 + 3 * 4096 + 100
    assert w(1, 116, target) == (COMM_SUCCESS, 0)
    clock.advance(10)
    assert r(1, 132) == target
    assert w(1, 64, 0, 1) == (COMM_SUCCESS, 0)
    assert r(1, 132) == target  # torque off keeps the multi-turn count
    assert bus.servo(1).read("present_position") == target
    bus.feed(p.build_packet(1, p.REBOOT))  # same packet the SDK's reboot() sends
    assert r(1, 132) == target % 4096


def test_homing_offset_and_reverse_mode(rig):
    bus, clock, w, r = rig
    base = r(1, 132)
    assert w(1, 20, 1000) == (COMM_SUCCESS, 0)
    assert r(1, 132) == base + 1000
    assert w(1, 10, 1, 1) == (COMM_SUCCESS, 0)  # reverse
    assert r(1, 132) == -base + 1000
    assert w(1, 11, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 104, 100) == (COMM_SUCCESS, 0)
    clock.advance(1.0)
    assert r(1, 128) == 100
    assert r(1, 132) > -base + 1000  # positive goal velocity moves the reported position up


def test_watchdog_stops_a_velocity_mode_servo(rig):
    bus, clock, w, r = rig
    assert w(1, 11, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 104, 100) == (COMM_SUCCESS, 0)
    assert w(1, 98, 5, 1) == (COMM_SUCCESS, 0)  # 100 ms
    clock.advance(0.05)
    assert r(1, 128) == 100
    clock.advance(0.5)  # the host goes quiet
    assert r(1, 128) == 0
    assert r(1, 98, 1, signed=False) == 255  # -1: bus watchdog error
    assert w(1, 104, 50) == (COMM_SUCCESS, p.ERR_DATA_RANGE)
    assert w(1, 98, 0, 1) == (COMM_SUCCESS, 0)
    assert w(1, 104, 50) == (COMM_SUCCESS, 0)
    clock.advance(0.2)
    assert r(1, 128) == 50


def test_velocity_ramps_at_profile_acceleration(rig):
    bus, clock, w, r = rig
    assert w(3, 11, 1, 1) == (COMM_SUCCESS, 0)
    assert w(3, 556, 100) == (COMM_SUCCESS, 0)  # 100 rev/min^2
    assert w(3, 512, 1, 1) == (COMM_SUCCESS, 0)
    assert w(3, 552, 1000) == (COMM_SUCCESS, 0)  # 10 rpm
    clock.advance(3.0)  # 100 rev/min^2 * 3 s = 5 rpm
    assert abs(r(3, 576) - 500) <= 1
    clock.advance(10)
    assert r(3, 576) == 1000


def test_current_and_pwm_modes_and_plausible_sensors(rig):
    bus, clock, w, r = rig
    assert w(1, 11, 0, 1) == (COMM_SUCCESS, 0)
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    assert w(1, 102, 300, 2) == (COMM_SUCCESS, 0)
    clock.advance(1)
    assert r(1, 126, 2) == 300
    assert r(1, 128) > 0
    assert r(1, 144, 2) == 120  # 12.0 V
    assert 20 <= r(1, 146, 1) <= 60
    assert w(2, 11, 16, 1) == (COMM_SUCCESS, 0)
    assert w(2, 64, 1, 1) == (COMM_SUCCESS, 0)
    assert w(2, 100, -400, 2) == (COMM_SUCCESS, 0)
    clock.advance(1)
    assert r(2, 124, 2) == -400
    assert r(2, 128) < 0


def test_realtime_tick_follows_time(rig):
    bus, clock, w, r = rig
    t0 = r(1, 120, 2, signed=False)
    clock.advance(0.25)
    assert r(1, 120, 2, signed=False) == (t0 + 250) % 32768


def test_hardware_error_drops_torque_and_sets_alert(rig, make_sdk):
    bus, clock, w, r = rig
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)
    bus.set_hardware_error(1, 0x04)  # overheating, in the default shutdown mask
    assert r(1, 64, 1) == 0
    assert w(1, 65, 1, 1) == (COMM_SUCCESS, p.ALERT_BIT)
    assert w(1, 64, 1, 1)[1] & 0x7F == p.ERR_RESULT_FAIL
    bus.feed(p.build_packet(1, p.REBOOT))
    assert r(1, 70, 1) == 0
    assert w(1, 64, 1, 1) == (COMM_SUCCESS, 0)


def test_external_ports(rig):
    bus, clock, w, r = rig
    assert [r(2, a, 2) for a in (152, 154, 156)] == [0, 0, 0]  # digital in, pull-down
    assert w(2, 56, 0, 1) == (COMM_SUCCESS, 0)  # analog in
    assert w(2, 57, 1, 1) == (COMM_SUCCESS, 0)  # digital out
    assert w(2, 58, 2, 1) == (COMM_SUCCESS, 0)  # digital in, pull-up
    assert w(2, 154, 1, 2) == (COMM_SUCCESS, 0)
    analog, out, pulled_up = (r(2, a, 2) for a in (152, 154, 156))
    assert 0 < analog < 4096 and out == 1 and pulled_up == 1
    assert r(3, 600, 2) == 0  # P series: four ports
    assert w(3, 59, 1, 1) == (COMM_SUCCESS, 0)
    assert w(3, 606, 1, 2) == (COMM_SUCCESS, 0)
    assert r(3, 606, 2) == 1
