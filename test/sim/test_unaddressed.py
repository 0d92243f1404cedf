"""sim.unaddressed: the armed gaps a servo's bus watchdog sees, from the instruction log."""
from __future__ import annotations

from dynamixel_handler import protocol as p
from dynamixel_handler.protocol.servo import LoggedInstruction
from dynamixel_handler.sim.unaddressed import unaddressed


def _write_watchdog(t: float, dxl_id: int, pulses: int) -> LoggedInstruction:
    return LoggedInstruction(t, p.WRITE, (dxl_id,), 98, 1, bytes([98, 0, pulses]))


def _sync_read(t: float, ids: tuple[int, ...]) -> LoggedInstruction:
    return LoggedInstruction(t, p.SYNC_READ, ids, 132, 4, bytes([132, 0, 4, 0, *ids]))


def _sync_write_watchdog(t: float, values: dict[int, int]) -> LoggedInstruction:
    params = bytes([98, 0, 1, 0]) + b"".join(bytes([i, v]) for i, v in values.items())
    return LoggedInstruction(t, p.SYNC_WRITE, tuple(values), 98, 1, params)


def test_gaps_count_only_while_armed_and_a_trip_stays_until_the_watchdog_is_written_again():
    log = [
        _sync_read(0.0, (1, 2)),            # not armed yet: a long gap does not count
        _write_watchdog(5.0, 1, 10),        # ID 1 armed, 200 ms
        _sync_read(5.1, (1, 2)),
        _sync_read(5.5, (1, 2)),            # 400 ms: a trip of ID 1
        _sync_read(6.0, (1, 2)),            # tripped: not armed (no gap, no trip) until written again
        _sync_write_watchdog(6.1, {1: 0, 2: 0}),
        _sync_write_watchdog(6.1, {1: 10, 2: 25}),  # both armed (200 ms, 500 ms)
        LoggedInstruction(6.2, p.PING, (p.BROADCAST_ID,), None, None, b""),  # a broadcast ping reaches both
        _sync_read(6.5, (1, 2)),            # 300 ms: ID 1 trips again, ID 2 (500 ms) not
    ]
    gaps = unaddressed(log, [1, 2])
    assert gaps.trips == {1: 2}
    assert abs(gaps.longest_s[1] - 0.4) < 1e-9 and abs(gaps.longest_s[2] - 0.3) < 1e-9
    assert gaps.worst == (1, gaps.longest_s[1])
    # only gaps that end from t0 on
    assert unaddressed(log, [1, 2], t0=6.2).trips == {1: 1}
