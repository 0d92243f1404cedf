"""Step, built on its own over the real parts it drives (``support.parts``, a fake bus): what one loop
sends and in which order, a silent servo pinged now and then with its line, the four phases one by
one, the read logs (values, servos that did not answer, hardware errors once each), and a request
that fails without stopping the loop. (test_step.py asks the same through the Handler front.)"""
from __future__ import annotations

import logging

from dynamixel_handler.core import log_limits
from dynamixel_handler.core.step import Step
from dynamixel_handler.settings import LogSettings, ReadRatios, Settings

from support.clock import HandClock
from support.fake_bus import XM430, FakeBus
from support.parts import Parts, build, lines_of
from support.queued import Asker, Led, Membership

ONLY_POSITION = ReadRatios(present={"pwm": 0, "current": 0, "velocity": 0, "position": 1, "velocity_trajectory": 0,
                                    "position_trajectory": 0, "input_voltage": 0, "temperature": 0},
                           groups={g: 0 for g in ("status", "goal", "gain", "limit", "error", "extra_dynamic",
                                                  "extra_static")})


def started(name: str, servos=None, ratios: ReadRatios = ONLY_POSITION, logs: LogSettings = LogSettings(),
            **changes) -> tuple[FakeBus, Parts, Step, list[str]]:
    bus = FakeBus(servos or {1: XM430, 2: XM430, 3: XM430})
    log, lines = lines_of(f"test_step_part.{name}", logging.INFO)
    parts = build(bus, Settings(ratios=ratios, logs=logs).but(scan__max_id=3, loop__rate_hz=100, **changes), log)
    parts.startup.start()
    parts.steps.step()  # loop 0 reads everything
    bus.calls.clear()
    lines.clear()
    return bus, parts, parts.steps, lines


def test_a_loop_runs_the_queued_requests_then_writes_what_is_pending_then_reads_what_is_due():
    bus, parts, step, _ = started("order")
    parts.intake.attach(Asker(parts.core))
    parts.intake.submit(Led(2))
    parts.pending.put("goal_position", {1: 1000, 3: 3000})
    report = step.step()
    assert [c[0] for c in bus.calls] == ["write", "sync_write", "sync_read"]
    assert bus.item_writes()[:2] == [("write", "led", (2, 1)), ("sync_write", "goal_position", {1: 1000, 3: 3000})]
    assert bus.calls[-1] == ("sync_read", 132, 4, (1, 2, 3), False)  # present position of every servo
    assert report.loop == 1 and report.present == {"position"} and step.loop_count == 2


def test_between_loops_the_queued_requests_and_their_writes_go_out_at_once_without_reads():
    bus, parts, step, _ = started("apply now")
    parts.intake.attach(Asker(parts.core))
    parts.intake.submit(Led(1))
    parts.pending.put("goal_position", {2: 2000})
    step.apply_now()
    assert [c[0] for c in bus.calls] == ["write", "sync_write"] and step.loop_count == 1



def test_a_silent_servo_is_left_out_of_the_reads_pinged_every_recheck_loops_loops_and_named_once(monkeypatch):
    clock = HandClock(100.0)
    monkeypatch.setattr(log_limits, "time", clock)
    bus, parts, step, lines = started("silent", loop__no_response_auto_remove=0)
    bus.silent.add(2)
    report = step.step()
    assert report.silent == [2] and parts.table.ping.tolist() == [True, False, True]
    assert lines == ["ID 2: no response (ping false)"]
    bus.calls.clear()
    for _ in range(step.settings.recheck_loops):
        step.step()
    assert all(read[3] == (1, 3) for read in bus.of("sync_read"))
    assert bus.of("ping") == [("ping", 2)]
    bus.silent.clear()
    clock.t += log_limits.LINE_INTERVAL_S
    while not parts.table.ping[1]:
        step.step()
    assert lines == ["ID 2: no response (ping false)", "ID 2: answers again"]


def test_the_phases_one_by_one_store_the_replies_only_when_finished():
    bus, parts, step, _ = started("phases")
    bus.set(1, "present_position", 777)
    report = step.begin_step()
    step.send_step(report)
    assert report.phase == 2 and parts.table.value("present_position", 1) != 777
    step.complete_step(report)
    assert report.phase == 3 and report.silent == [] and parts.table.value("present_position", 1) != 777
    step.finish_step(report)
    assert report.phase == 4 and parts.table.value("present_position", 1) == 777
    step.finish_step(report)  # once only
    assert report.phase == 4


def test_the_read_logs_give_the_values_max_width_a_line_and_the_servos_that_did_not_answer():
    logs = LogSettings(max_width=2, reads_raw=frozenset({"present"}), reads_err=frozenset({"present"}))
    bus, _, step, lines = started("read logs", logs=logs, loop__no_response_auto_remove=0)
    for dxl_id, value in ((1, 100), (2, 200), (3, 300)):
        bus.set(dxl_id, "present_position", value)
    step.step()
    assert lines == ["read present present_position: 1=100, 2=200\n  3=300"]
    bus.silent.add(3)
    step.step()
    assert "read present: no answer from IDs [3]" in lines


def test_a_hardware_error_read_is_an_error_line_once_naming_the_cause_and_the_shortcut():
    ratios = ReadRatios(present=dict(ONLY_POSITION.present), groups={**ONLY_POSITION.groups, "error": 1})
    bus, _, step, lines = started("errors", ratios=ratios)
    bus.set(2, "hardware_error_status", 0x20)
    step.step()
    step.step()
    errors = [line for line in lines if line.startswith("ID 2: hardware error")]
    assert len(errors) == 1 and "(0x20)" in errors[0] and "overload" in errors[0]
    assert errors[0].endswith("clear it with the shortcut clear_error (CE)")
    bus.set(2, "hardware_error_status", 0x24)  # another cause too: said again
    step.step()
    assert len([line for line in lines if line.startswith("ID 2: hardware error")]) == 2


def test_a_request_no_part_takes_is_one_error_line_and_the_loop_goes_on():
    bus, parts, step, lines = started("bad request")

    class Unknown:
        what = "mystery"

    parts.intake.submit(Unknown())
    parts.pending.put("goal_position", {1: 1500})
    step.step()
    assert lines == ["mystery failed: TypeError: no part takes a Unknown request (the part that takes it is "
                     "attached by who builds it: handler.attach(part))"]
    assert ("sync_write", "goal_position", {1: 1500}) in bus.item_writes()


def test_add_id_asked_many_times_in_a_loop_pings_once_in_that_loop():
    bus, parts, step, _ = started("membership", servos={1: XM430, 2: XM430, 4: XM430})
    parts.intake.attach(Asker(parts.core))
    for _ in range(5):
        parts.intake.submit(Membership(4, True))
        parts.intake.submit(Membership(4, False))
    parts.intake.submit(Membership(4, True))
    step.step()
    assert bus.of("ping") == [("ping", 4)] and list(parts.table.ids) == [1, 2, 4]
