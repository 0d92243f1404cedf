"""Step: what one loop sends and in which order (operations, writes, reads), the pings of a silent
servo, and the four phases one by one (on a fake bus, through the Handler front)."""
from __future__ import annotations

import logging

from dynamixel_handler.config import defaults, validate
from dynamixel_handler.core.handler import RECHECK_LOOPS, Handler

from support.fake_bus import XM430, FakeBus
from support.queued import Asker, Led

LOG = logging.getLogger("test_step")
ONLY_POSITION = {f"pub_ratio/present.{k}": 0 for k in ("pwm", "current", "velocity", "input_voltage", "temperature")} | {
    "pub_ratio/present.position": 1, "pub_ratio/status": 0, "pub_ratio/goal": 0, "pub_ratio/gain": 0,
    "pub_ratio/limit": 0, "pub_ratio/error": 0, "pub_ratio/extra.dynamic_items": 0, "pub_ratio/extra.static_items": 0}


def started(**params) -> tuple[FakeBus, Handler]:
    bus = FakeBus({1: XM430, 2: XM430, 3: XM430})
    h = Handler(bus, validate({**defaults(), "init/servo_auto_search.max_id": 3, "loop_rate": 100,
                               **ONLY_POSITION, **params}), LOG)
    h.start()
    h.step()  # loop 0 reads everything
    bus.calls.clear()
    return bus, h


def test_a_loop_runs_the_operations_then_writes_then_reads_what_is_due():
    bus, h = started()
    h.attach(Asker(h.core))
    h.submit(Led(2))  # queued: a RAM write the loop makes first
    h.pending.put("goal_position", {1: 1000, 3: 3000})
    report = h.step()
    assert [c[0] for c in bus.calls] == ["write", "sync_write", "sync_read"]
    assert bus.calls[-1] == ("sync_read", 132, 4, (1, 2, 3), False)
    assert report.loop == 1 and report.present == {"position"} and h.figures().loop_count == 2


def test_a_silent_servo_is_not_read_but_pinged_every_recheck_loops_loops():
    bus, h = started(no_response_id_auto_remove_count=0)
    bus.silent.add(2)
    h.step()
    assert h.table.ping.tolist() == [True, False, True]
    bus.calls.clear()
    for _ in range(RECHECK_LOOPS):
        h.step()
    reads = bus.of("sync_read")
    assert len(reads) == RECHECK_LOOPS and all(r[3] == (1, 3) for r in reads)
    assert bus.of("ping") == [("ping", 2)]


def test_the_phases_one_by_one_store_the_replies_only_when_finished():
    bus, h = started()
    bus.set(1, "present_position", 777)
    report = h.steps.begin_step()
    h.steps.send_step(report)
    assert report.phase == 2 and h.table.value("present_position", 1) != 777
    h.steps.complete_step(report)
    assert report.silent == [] and h.table.value("present_position", 1) != 777
    h.steps.finish_step(report)
    assert report.phase == 4 and h.table.value("present_position", 1) == 777
