"""No armed servo goes unaddressed longer than its bus watchdog time on a slow bus: a long read is
cut into narrower spans and a burst of mode changes is spread over loops while watchdogs are armed.

Measured where the servos feel it: from the virtual bus's instruction log, the longest time each
armed servo went without any instruction naming it (``sim.unaddressed``), against the watchdog time
the node wrote; and the node's own "bus watchdog tripped" lines."""
from __future__ import annotations

import time

import pytest

from dynamixel_handler.sim.unaddressed import unaddressed

from support.rig import Rig

X = 1020
pytestmark = pytest.mark.slow


#: a loaded host delays the virtual bus's replies (it serves from this test process): an adapter
#: latency of 16 ms, an FTDI adapter's default, gives the reply timeouts room, so that a late reply is
#: not taken for a silent servo (which is then left out of the reads and only pinged)
PATIENT = "latency_timer:=16"


def _velocity(rig: Rig, ids: list[int]) -> None:
    from dynamixel_handler_msgs.msg import DynamixelControlXVelocity
    rig.publish("/dynamixel/command/x/velocity_control",
                DynamixelControlXVelocity(id_list=ids, velocity_deg_s=[20.0] * len(ids)))


def _armed(rig: Rig, ids: list[int]) -> bool:
    return all(rig.sim.servo(i).read("operating_mode") == 1 and rig.sim.servo(i).read("bus_watchdog") > 0
               for i in ids)


def _check(rig: Rig, ids: list[int], t0: float) -> None:
    gaps = unaddressed(rig.sim.log, ids, t0, time.monotonic())
    worst_id, worst_s = gaps.worst
    assert gaps.longest_s, "no servo was armed"
    assert gaps.trip_count == 0, (f"trips {gaps.trips}; longest armed gap {worst_s:.2f} s (ID {worst_id})",
                                  rig.output[-3000:])
    assert "bus watchdog tripped" not in rig.output and "had tripped" not in rig.output, rig.output[-3000:]


def test_long_reads_are_cut_so_armed_servos_are_addressed_within_their_watchdog_time():
    """Every 10th loop reads every group (0..147 of the control table: ~1 s at 9600 bps for six
    servos), the others only the present position (0.1 s): the watchdog follows the average loop
    (~0.75 s), so one whole read is longer than it."""
    ids = list(range(1, 7))
    ratios = [f"pub_ratio/{g}:=10" for g in ("status", "goal", "gain", "limit", "error", "extra.dynamic_items",
                                             "extra.static_items", "present.input_voltage", "present.temperature",
                                             "present.pwm", "present.current", "present.velocity")]
    rig = Rig({i: X for i in ids}, "baudrate:=9600", "loop_rate:=100", PATIENT, "pub_ratio/present.position:=1", *ratios,
              sim_kwargs={"wire_timing": True, "baudrate": 9600})
    try:
        _velocity(rig, ids)
        rig.wait(lambda: _armed(rig, ids), timeout=30, what="all six in velocity mode, watchdogs armed")
        t0 = time.monotonic()
        time.sleep(12.0)  # a few long-read loops and the watchdog time following the loop
        rig.fresh_states(count=3, timeout=30)
        _check(rig, ids, t0)
    finally:
        assert rig.close() == 0


def test_a_burst_of_mode_changes_waits_between_loops_while_other_servos_are_armed():
    """Three servos run in velocity mode (armed); six more are switched at once at 9600 bps (~0.35 s
    a mode change): made one after the other they would leave the three unaddressed for ~2 s."""
    ids = list(range(1, 10))
    rig = Rig({i: X for i in ids}, "baudrate:=9600", "loop_rate:=100", PATIENT,
              sim_kwargs={"wire_timing": True, "baudrate": 9600})
    try:
        _velocity(rig, [1, 2, 3])
        rig.wait(lambda: _armed(rig, [1, 2, 3]), timeout=30, what="three in velocity mode, watchdogs armed")
        rig.fresh_states(count=4, timeout=30)  # the watchdog time follows the loop
        t0 = time.monotonic()
        _velocity(rig, ids[3:])
        rig.wait(lambda: _armed(rig, ids), timeout=60, what="all nine in velocity mode, watchdogs armed")
        rig.fresh_states(count=3, timeout=30)
        _check(rig, ids, t0)
        # every servo got its goal after its mode change
        goals = {i: rig.sim.servo(i).read("goal_velocity") for i in ids}
        assert all(g != 0 for g in goals.values()), (goals, rig.output[-4000:])
    finally:
        assert rig.close() == 0
