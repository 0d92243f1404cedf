"""Intake: request values queued by any thread, taken in order by the loop thread and handed to
the one part attached for each type (its ``handle``); a part that raises is one line and the rest
still run; a request of a type nobody takes is one line too; a type taken by two parts is refused
when the second is attached, and the routes are the parts' own ``TAKES``."""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import ClassVar, assert_never

import pytest

from dynamixel_handler.bus import Result
from dynamixel_handler.bus.result import Failure
from dynamixel_handler.core.intake import Intake, label
from dynamixel_handler.core.request_types import DONE, Answer, EngageStop, Outcome, answer


@dataclass(frozen=True)
class Note:
    text: str
    what: str = "note"


@dataclass(frozen=True)
class Broken:
    what: str = "broken"


class Notes:
    """A part that takes notes and breaks on ``Broken``."""

    TAKES: ClassVar[tuple[type, ...]] = (Note, Broken)

    def __init__(self) -> None:
        self.done: list[str] = []

    def handle(self, request: Note | Broken) -> None:
        match request:
            case Note(text=text):
                self.done.append(text)
            case Broken():
                raise ZeroDivisionError("division by zero")
            case _:
                assert_never(request)


class Other:
    TAKES: ClassVar[tuple[type, ...]] = (Note,)

    def handle(self, request: Note) -> None:
        raise AssertionError("never taken")


def intake() -> tuple[Intake, Notes, list[str]]:
    lines: list[str] = []
    log = logging.getLogger(f"test_intake_{len(lines)}_{id(lines)}")
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    part = Intake(log)
    notes = Notes()
    part.attach(notes)
    return part, notes, lines


def test_queued_requests_run_in_order_and_one_that_raises_is_logged_and_the_rest_still_run():
    part, notes, lines = intake()
    part.submit(Note("first"))
    part.submit(Broken())
    part.submit(Note("third"), "the third")
    assert notes.done == []  # nothing runs before the loop takes them
    part.run_queued()
    assert notes.done == ["first", "third"]
    assert lines == ["broken failed: ZeroDivisionError: division by zero"]
    part.submit(Note("dropped"))
    assert part.drop() == 1
    part.run_queued()
    assert notes.done == ["first", "third"]


def test_a_request_nobody_takes_is_one_line_and_the_queue_goes_on():
    part, notes, lines = intake()
    part.submit(EngageStop("nobody attached the E-stop here"))
    part.submit(Note("after"))
    part.run_queued()
    assert lines == ["e-stop failed: TypeError: no part takes a EngageStop request (the part that takes it is "
                     "attached by who builds it: handler.attach(part))"]
    assert notes.done == ["after"]
    assert part.routes() == {Note: "Notes", Broken: "Notes"}


def test_answers_and_labels():
    assert answer(Result(True)) is DONE and answer(True) is DONE
    assert answer(Result(False, Failure.NO_REPLY, "no reply")) == Answer(Outcome.FAILED, "no reply")
    assert answer(False, "not added") == Answer(Outcome.FAILED, "not added")
    assert label(Note("x")) == "note" and label(object()) == "object"


def test_a_second_part_for_one_request_type_is_refused_and_the_first_kept():
    part, notes, _ = intake()
    with pytest.raises(ValueError, match="Note already taken by Notes: one part per request type"):
        part.attach(Other())
    with pytest.raises(ValueError, match="Note, Broken already taken by Notes"):
        part.attach(Notes())  # the same part type attached twice: as an error too
    part.submit(Note("still the first"))
    part.run_queued()
    assert notes.done == ["still the first"]
