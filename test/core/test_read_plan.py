"""ReadPlan: which sync reads a loop sends for given ratios and servos, the Fast Sync Read
fallback, and how replies are stored (a fake bus records every read)."""
from __future__ import annotations

import logging

import numpy as np

from dynamixel_handler.bus.ops import SyncRead
from dynamixel_handler.core.pacing import Pacing
from dynamixel_handler.core.read_plan import FAST_MISSES_PLAIN, ReadPlan, ReadSettings, due_items_plain
from dynamixel_handler.settings import GROUP_RATIOS, PRESENT_RATIOS, ReadRatios

from support.fake_bus import H54, XM430, XM540, FakeBus, table_of

LOG = logging.getLogger("test_read_plan")


def ratios(present: dict[str, int] | None = None, **groups: int) -> ReadRatios:
    """Every ratio 0 (read at start only) but those given."""
    return ReadRatios(present={k: 0 for k in PRESENT_RATIOS} | (present or {}),
                      groups={g: 0 for g in GROUP_RATIOS} | groups)


def plan_for(servos, settings: ReadSettings, baudrate: int = 1_000_000):
    bus = FakeBus(servos, baudrate=baudrate)
    table = table_of(bus)
    plan = ReadPlan(bus, table, LOG, Pacing(bus, table, lambda: False), settings)
    return bus, table, plan


def reads_of(plan: ReadPlan, table, loop: int, live=None):
    items = plan.due(loop)[3]
    live = np.ones(len(table), dtype=bool) if live is None else live
    return [(r.address, r.length, r.ids, [p.item for p in r.parts]) for r in plan.plan(items, live)]


def test_present_values_every_loop_are_one_span_per_layout_and_other_groups_only_when_due():
    _, table, plan = plan_for({1: XM430, 2: XM540, 3: H54},
                              ReadSettings(ratios({"current": 1, "velocity": 1, "position": 1}, goal=3)))
    # X servos share a layout: current (126), velocity (128), position (132) in one span of 10 bytes;
    # the Pro H54 has them elsewhere (position 611, velocity 615, current 621): its own read
    assert sorted(reads_of(plan, table, 1)) == [
        (126, 10, (1, 2), ["present_current", "present_velocity", "present_position"]),
        (611, 12, (3,), ["present_position", "present_velocity", "present_current"]),
    ]
    loop3 = reads_of(plan, table, 3)
    assert any("goal_position" in parts for *_, parts in loop3)
    assert not any("goal_position" in parts for *_, parts in reads_of(plan, table, 4))


def test_split_read_reads_each_item_on_its_own_and_silent_servos_are_left_out():
    _, table, plan = plan_for({1: XM430, 2: XM430, 3: XM430},
                              ReadSettings(ratios({"current": 1, "position": 1}), split_read=True))
    live = np.array([True, False, True])
    assert reads_of(plan, table, 1, live) == [(126, 2, (1, 3), ["present_current"]),
                                              (132, 4, (1, 3), ["present_position"])]


def test_a_ratio_of_zero_reads_only_in_the_first_loop_and_due_follows_new_settings():
    settings = ReadSettings(ratios({"position": 0}, status=0))
    _, table, plan = plan_for({1: XM430}, settings)
    assert "present_position" in plan.due(0)[0] and "status" in plan.due(0)[2]
    assert plan.due(1)[0] == ()
    plan.settings = ReadSettings(ratios({"position": 2}))
    assert plan.due(2)[0] == ("present_position",) and plan.due(3)[0] == ()
    for loop in (0, 1, 2, 6, 7):
        assert plan.due(loop) == due_items_plain(plan.settings.ratios, loop)


def test_an_armed_watchdog_on_a_slow_bus_cuts_a_wide_read_into_narrower_spans():
    servos = {i: XM430 for i in range(1, 11)}
    settings = ReadSettings(ratios({"pwm": 1, "current": 1, "velocity": 1, "position": 1, "input_voltage": 1,
                                    "temperature": 1}))
    _, table, plan = plan_for(servos, settings, baudrate=57600)
    whole = reads_of(plan, table, 1)
    assert len(whole) == 1  # 124..146 in one span
    for dxl_id in servos:
        table.set_value("bus_watchdog", dxl_id, 5)  # 100 ms armed
    cut = reads_of(plan, table, 1)
    assert len(cut) > 1 and max(length for _, length, _, _ in cut) < whole[0][1]
    assert sorted(p for *_, parts in cut for p in parts) == sorted(whole[0][3])  # nothing left out


def test_a_servo_that_never_answers_fast_sync_read_is_read_plainly_after_three_misses():
    bus, table, plan = plan_for({1: XM430, 2: XM430, 3: XM430}, ReadSettings(ratios({"position": 1}), fast_read=True))
    bus.no_fast.add(2)
    for _ in range(FAST_MISSES_PLAIN):
        (read,) = plan.plan(plan.due(1)[3], np.ones(3, dtype=bool))
        assert read.fast
        bus.calls.clear()
        data = plan.gather(read, bus.execute(SyncRead(read.address, read.length, read.ids, read.fast, protocol=2)).value)
        assert sorted(data) == [1, 2, 3]  # servos 2 and 3 completed by a plain Sync Read
        assert bus.calls[-1] == ("sync_read", 132, 4, (2, 3), False)
    reads = plan.plan(plan.due(1)[3], np.ones(3, dtype=bool))
    assert sorted((r.ids, r.fast) for r in reads) == [((1, 3), True), ((2,), False)]


def test_replies_are_stored_decoded_and_a_value_the_host_set_after_the_read_went_out_is_kept():
    bus, table, plan = plan_for({1: XM430, 2: XM430}, ReadSettings(ratios({"position": 1}, goal=1)))
    bus.set(1, "present_position", -1234)
    bus.set(2, "present_position", 4000)
    bus.set(1, "goal_position", 10)
    bus.set(2, "goal_position", 20)
    seq = table.seq
    sent = [(r, bus.execute(SyncRead(r.address, r.length, r.ids, protocol=2)).value)
            for r in plan.plan(plan.due(1)[3], np.ones(2, dtype=bool))]
    table.set_value("goal_position", 2, 99)  # the host's own value, newer than the read
    table.note_set("goal_position", [2])
    for read, data in sent:
        plan.store(read, data, stamp=1.0, seq=seq)
    assert table.value("present_position", 1) == -1234 and table.value("present_position", 2) == 4000
    assert table.value("goal_position", 1) == 10 and table.value("goal_position", 2) == 99


def test_the_wire_time_estimate_counts_every_servo_and_the_adapter_latency():
    _, table, plan = plan_for({1: XM430, 2: XM430}, ReadSettings(ratios({"position": 2})), baudrate=1_000_000)
    # one read of 4 bytes from 2 servos every 2 loops: (14 + 2 + 2 x (11 + 4)) bytes at 10 us + 2 ms latency
    assert abs(plan.wire_s_per_loop() - ((14 + 2 + 2 * 15) * 10e-6 + 0.002) / 2) < 1e-9
