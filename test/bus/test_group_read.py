"""GroupRead: its result is gathered once, by the function it was given; the ID checks."""
from __future__ import annotations

import pytest

from dynamixel_handler.bus.group_read import GroupRead, check_id, reply_bytes, unique_ids
from dynamixel_handler.bus.result import Failure


def test_the_result_is_gathered_once_and_kept():
    calls: list[GroupRead] = []

    def gather(read: GroupRead) -> None:
        calls.append(read)
        read.finish({1: b"\x01"}, "")

    read = GroupRead(gather, b"packet", [(1, 1)], False, "sync read @146x1")
    assert not read.done
    assert read.result() == {1: b"\x01"} and read.result() == {1: b"\x01"}
    assert calls == [read] and read.done


def test_a_read_that_found_nobody_keeps_why():
    read = GroupRead(lambda r: r.finish({}, Failure.NOBODY_ANSWERED, "sync read @146x1: no servo answered"), b"p", [(1, 1)], False,
                     "")
    assert read.result() == {} and read.failure is Failure.NOBODY_ANSWERED and read.why == "sync read @146x1: no servo answered"


def test_a_finished_read_needs_no_bus():
    assert GroupRead.finished({2: b"\x02"}).result() == {2: b"\x02"}


def test_reply_bytes_count_one_status_each_or_one_fast_packet():
    assert reply_bytes([(1, 4), (2, 4)], False) == 2 * (11 + 4)
    assert reply_bytes([(1, 4), (2, 4)], True) == 8 + 2 * (4 + 4)


def test_ids_are_plain_ints_in_range_and_kept_in_order_once():
    assert unique_ids([3, 1, 3, True]) == [3, 1]
    assert check_id(252) == 252
    for bad in (253, -1, 1.5, "1"):
        with pytest.raises(ValueError, match="invalid Dynamixel ID"):
            check_id(bad)  # type: ignore[arg-type]
