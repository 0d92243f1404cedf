"""LogLimits and PingLog: the loop's lines that can repeat come at most once a second per cause and
servo, the next line says how many were left out, and the last ping line of a servo always tells
the state it is in (a line whose second has not passed yet comes once it has)."""
from __future__ import annotations

import logging

from dynamixel_handler import logs
from dynamixel_handler.core.log_limits import LINE_INTERVAL_S, LogLimits, PingLog

from support.clock import HandClock


def limits(monkeypatch) -> tuple[LogLimits, list[tuple[int, str]], HandClock]:
    clock = HandClock(500.0)
    monkeypatch.setattr(logs, "time", clock)
    lines: list[tuple[int, str]] = []
    return LogLimits(lambda level, msg: lines.append((level, msg))), lines, clock


def test_a_line_repeated_within_a_second_is_left_out_and_counted_in_the_next_one(monkeypatch):
    limited, lines, clock = limits(monkeypatch)
    assert limited(logging.WARNING, "ID 3: no answer to ping, not added", "not added 3")
    for _ in range(4):
        assert not limited(logging.WARNING, "ID 3: no answer to ping, not added", "not added 3")
    assert lines == [(logging.WARNING, "ID 3: no answer to ping, not added")]
    clock.t += LINE_INTERVAL_S
    assert limited(logging.WARNING, "ID 3: no answer to ping, not added", "not added 3")
    assert lines[-1] == (logging.WARNING, "ID 3: no answer to ping, not added (4 more)")


def test_each_servo_and_each_level_has_its_own_second(monkeypatch):
    limited, lines, _ = limits(monkeypatch)
    limited(logging.INFO, "ID 1: operating mode -> velocity", "mode 1")
    limited(logging.INFO, "ID 2: operating mode -> velocity", "mode 2")       # another servo
    limited(logging.WARNING, "ID 1: reboot refused", "mode 1")                  # another level
    limited(logging.INFO, "ID 1: operating mode -> pwm", "mode 1")              # the same cause: left out
    assert [msg for _, msg in lines] == ["ID 1: operating mode -> velocity", "ID 2: operating mode -> velocity",
                                         "ID 1: reboot refused"]
    assert [level for level, _ in lines] == [logging.INFO, logging.INFO, logging.WARNING]


def ping_log() -> tuple[PingLog, list[tuple[int, str]]]:
    lines: list[tuple[int, str]] = []
    return PingLog(lambda level, msg: lines.append((level, msg))), lines


def test_a_servo_going_silent_is_a_warning_and_answering_again_an_info_line():
    log, lines = ping_log()
    log.change(2, False, now=10.0)
    log.change(2, True, now=12.0)
    assert lines == [(logging.WARNING, "ID 2: no response (ping false)"), (logging.INFO, "ID 2: answers again")]


def test_a_noisy_servo_gets_one_line_a_second_and_its_last_line_tells_its_state():
    log, lines = ping_log()
    log.change(2, False, now=10.0)
    log.change(2, True, now=10.1)    # left out: within the second
    log.change(2, False, now=10.2)
    log.change(2, True, now=10.3)
    log.flush(now=10.5)
    assert lines == [(logging.WARNING, "ID 2: no response (ping false)")]
    log.flush(now=11.0)              # the second is over and the servo answers: said, with the count
    assert lines[-1] == (logging.INFO, "ID 2: answers again (2 more changes between silent and answering "
                                       "in the last 1 s)")
    log.change(3, False, now=20.0)
    log.change(3, True, now=20.1)
    log.change(3, False, now=20.2)
    log.flush(now=21.5)              # back to the state the last line said: nothing to add
    assert lines[-1] == (logging.WARNING, "ID 3: no response (ping false)") and len(lines) == 3


def test_a_removed_servo_is_forgotten_and_a_new_one_of_that_id_starts_afresh():
    log, lines = ping_log()
    log.change(4, False, now=1.0)
    log.change(4, True, now=1.2)
    log.forget(4)
    log.flush(now=5.0)
    assert lines == [(logging.WARNING, "ID 4: no response (ping false)")]
    log.change(4, False, now=5.1)
    assert lines[-1] == (logging.WARNING, "ID 4: no response (ping false)") and len(lines) == 2
