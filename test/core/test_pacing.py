"""Pacing: the shortest armed bus watchdog, the read span it allows on a slow bus, and how many
mode changes may hold the bus between two reads."""
from __future__ import annotations

from dynamixel_handler.core import pacing as pacing_module
from dynamixel_handler.core.pacing import MIN_SPAN, OPS_SHARE, Pacing
from dynamixel_handler.core.request_types import Later

from support.clock import HandClock
from support.fake_bus import H54, XM430, FakeBus, table_of


def test_the_shortest_armed_watchdog_is_the_smallest_positive_one_known():
    bus = FakeBus({1: XM430, 2: XM430, 3: H54})
    table = table_of(bus)
    part = Pacing(bus, table, lambda: False)
    assert part.shortest_armed_s() is None
    table.set_value("bus_watchdog", 1, 10)
    table.set_value("bus_watchdog", 2, 0)   # off
    assert part.shortest_armed_s() == 0.2
    table.set_value("bus_watchdog", 2, 3)
    assert part.shortest_armed_s() == 0.06


def test_the_read_span_fits_a_third_of_the_watchdog_time_on_the_wire_or_is_not_cut_at_all():
    bus = FakeBus({1: XM430}, baudrate=57600, latency_timer_ms=1.0)
    table = table_of(bus)
    part = Pacing(bus, table, lambda: False)
    assert part.read_span_limit(10) is None  # nothing armed
    table.set_value("bus_watchdog", 1, 5)    # 100 ms: a third is 33 ms - 2 ms latency = 180 bytes at 57600 bps
    assert part.read_span_limit(10) == int((180 - 14 - 10) / 10) - 11
    table.set_value("bus_watchdog", 1, 1)    # 20 ms: no 4-byte item of 10 servos fits: not cut
    assert part.read_span_limit(10) is None and MIN_SPAN == 4


def test_mode_changes_after_the_reads_stop_at_their_share_of_the_watchdog_and_a_stop_drops_them(monkeypatch):
    clock = HandClock(50.0)
    monkeypatch.setattr(pacing_module, "time", clock)
    stopping = [False]
    bus = FakeBus({1: XM430})
    table = table_of(bus)
    part = Pacing(bus, table, lambda: stopping[0])
    assert part.ops_wait() is None and part.ops_wait() is None  # nothing armed: never waits
    table.set_value("bus_watchdog", 1, 10)  # 200 ms
    part.note_reads_sent()
    assert part.ops_wait() is None          # one is always made after the reads
    clock.t += OPS_SHARE * 0.2 + 0.001
    assert part.ops_wait() is Later.BUS_TIME
    part.note_reads_sent()
    assert part.ops_wait() is None
    stopping[0] = True
    assert part.ops_wait() is Later.STOPPING
    part.drop_mode_change(1)  # the request that answered "stopping": not made, the shutdown knows
    assert part.dropped_mode_changes == {1}
