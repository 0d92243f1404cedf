"""ReplyFaults: corrupted, cut and noisy replies on their way out."""
from __future__ import annotations

import collections
import random

from dynamixel_handler.sim.faults import ReplyFaults

REPLY = bytes([0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x04, 0x00, 0x55, 0x00, 0xA1, 0x0C])


def faults() -> tuple[ReplyFaults, collections.Counter[str]]:
    counts: collections.Counter[str] = collections.Counter()
    return ReplyFaults(random.Random(1), counts), counts


def test_replies_pass_untouched_by_default():
    f, counts = faults()
    assert f.apply([(0.0, REPLY), (0.001, REPLY)]) == [(0.0, REPLY), (0.001, REPLY)]
    assert not counts


def test_a_truncated_reply_is_its_first_half_and_only_the_next_ones_are_cut():
    f, counts = faults()
    f.truncate_next(1)
    out = f.apply([(0.0, REPLY), (0.0, REPLY)])
    assert out == [(0.0, REPLY[:5]), (0.0, REPLY)] and counts["truncated"] == 1


def test_noise_goes_before_the_first_reply_once_and_is_never_a_header():
    f, _ = faults()
    f.inject_garbage(50)
    first = f.apply([(0.0, REPLY), (0.0, REPLY)])
    assert first[0][1].endswith(REPLY) and len(first[0][1]) == len(REPLY) + 50
    assert 0xFF not in first[0][1][:50] and first[1][1] == REPLY
    assert f.apply([(0.0, REPLY)]) == [(0.0, REPLY)]


def test_every_reply_is_corrupted_at_rate_one():
    f, counts = faults()
    f.crc_error_rate = 1.0
    out = f.apply([(0.0, REPLY)])
    assert out[0][1][:-1] == REPLY[:-1] and out[0][1][-1] == REPLY[-1] ^ 0x5A
    assert counts["crc_corrupted"] == 1
