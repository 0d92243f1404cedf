"""Return Delay Time (address 9, 2 us per unit) is honoured when the wire is timed: a servo's
status packet starts no earlier than its delay after the instruction, and a servo set to 0
answers sooner. Only the real dynamixel_sdk talks to the bus. The bounds are behaviour (a lower
bound a loaded machine can only exceed, and a difference of the fastest round trips), not speed
targets."""

from __future__ import annotations

import statistics
import time

from dynamixel_sdk import COMM_SUCCESS

RETURN_DELAY_TIME = 9
PINGS = 100


def _ping_pairs(port, ph) -> tuple[list[float], list[float]]:
    """Round-trip times of PINGS answered pings to servo 1 and to servo 2, taken in turns so both
    see the same load (a ping the host gave up on under load is repeated)."""
    times: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(3 * PINGS):
        for sid in (1, 2):
            if len(times[sid]) == PINGS:
                continue
            start = time.perf_counter()
            model, result, error = ph.ping(port, sid)
            if result == COMM_SUCCESS:
                assert (model, error) == (1020, 0)
                times[sid].append(time.perf_counter() - start)
        if all(len(t) == PINGS for t in times.values()):
            return times[1], times[2]
    raise AssertionError(f"only {len(times[1])} + {len(times[2])} of {3 * PINGS} pings each answered")


def test_replies_wait_for_the_return_delay_time_and_come_sooner_at_zero(make_bus, make_sdk):
    bus = make_bus({1: 1020, 2: 1020}, wire_timing=True)  # 1 Mbps, Return Delay Time unboxed: 250 (500 us)
    port, ph = make_sdk(bus.path)
    assert ph.read1ByteTxRx(port, 1, RETURN_DELAY_TIME) == (250, COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 2, RETURN_DELAY_TIME, 0) == (COMM_SUCCESS, 0)

    slow, fast = _ping_pairs(port, ph)
    assert min(slow) >= 500e-6  # no reply before the servo's 500 us, however fast the host

    # each reply at delay 250 waits 500 us more than at 0: load only ever adds time, so the fastest
    # of 100 pings shows the servo's own delay (medians or means would carry the machine's stalls)
    assert min(slow) - min(fast) >= 400e-6, (
        f"fastest ping {min(slow) * 1e3:.3f} ms at 250, {min(fast) * 1e3:.3f} ms at 0 "
        f"(medians {statistics.median(slow) * 1e3:.3f} / {statistics.median(fast) * 1e3:.3f} ms)")
