"""Intake: request values queued by any thread, taken in order by the loop thread and handed to
the one handler registered for each type; a handler that raises is one line and the rest still
run; a request of a type nobody takes is refused when asked for."""
from __future__ import annotations

import logging
from dataclasses import dataclass

import pytest

from dynamixel_handler.bus import Result
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.core.intake import Intake, label
from dynamixel_handler.core.request_types import DONE, Answer, Outcome, WriteItem, answer


@dataclass(frozen=True)
class Note:
    text: str
    what: str = "note"


@dataclass(frozen=True)
class Broken:
    what: str = "broken"


def intake() -> tuple[Intake, list[str], list[str]]:
    lines: list[str] = []
    log = logging.getLogger(f"test_intake_{len(lines)}_{id(lines)}")
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    part = Intake(log)
    done: list[str] = []
    part.register(Note, lambda r: done.append(r.text))
    part.register(Broken, lambda r: 1 / 0)
    return part, done, lines


def test_queued_requests_run_in_order_and_one_that_raises_is_logged_and_the_rest_still_run():
    part, done, lines = intake()
    part.submit(Note("first"))
    part.submit(Broken())
    part.submit(Note("third"), "the third")
    assert done == []  # nothing runs before the loop takes them
    part.run_queued()
    assert done == ["first", "third"]
    assert lines == ["broken failed: ZeroDivisionError: division by zero"]
    part.submit(Note("dropped"))
    assert part.drop() == 1
    part.run_queued()
    assert done == ["first", "third"]


def test_asked_now_a_request_goes_to_its_handler_and_a_handler_that_answers_nothing_did_it():
    part, done, _ = intake()
    assert part.ask(Note("now")) is DONE and done == ["now"]

    @dataclass(frozen=True)
    class Refused:
        text: str

    part.register(Refused, lambda r: Answer(Outcome.REFUSED, f"no {r.text}"))
    assert part.ask(Refused("x")) == Answer(Outcome.REFUSED, "no x") and not part.ask(Refused("x"))
    with pytest.raises(TypeError, match="WriteItem"):
        part.ask(WriteItem(1, "led", 1))
    assert set(part.routes()) == {Note, Broken, Refused}


def test_answers_and_labels():
    assert answer(Result(True)) is DONE and answer(True) is DONE
    assert answer(Result(False, Failure.NO_REPLY, "no reply")) == Answer(Outcome.FAILED, "no reply")
    assert answer(False, "not added") == Answer(Outcome.FAILED, "not added")
    assert label(Note("x")) == "note" and label(object()) == "object"


def test_a_second_handler_for_one_request_type_is_refused_and_the_first_kept():
    part, done, _ = intake()
    try:
        part.register(Note, lambda r: None)
    except ValueError as err:
        assert "Note already has a handler" in str(err)
    else:
        raise AssertionError("a second route for Note was taken")
    part.ask(Note("still the first"))
    assert done == ["still the first"]
