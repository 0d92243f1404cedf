"""The start-up scan (``core/scan.py``) on its own over a fake bus: the ID range asked, Protocol 1.0
servos pinged ID by ID where a Protocol 1.0 family is used, and, where none is and too few servos
answer, the Protocol 1.0 servos that do answer named with the parameter that drives them."""
from __future__ import annotations

import logging
import threading

import pytest

from dynamixel_handler.core.scan import Scan, lookup
from dynamixel_handler.errors import StartupError
from dynamixel_handler.settings import ScanSettings

from support.fake_bus import XM430, FakeBus
from support.parts import lines_of

AX12A, MX28 = 12, 29


def problem(message: str) -> None:
    raise StartupError(message)


def scan(bus: FakeBus, name: str, **settings) -> tuple[Scan, list[str]]:
    log, lines = lines_of(f"test_scan.{name}", logging.INFO)
    return Scan(bus, log, ScanSettings(min_id=1, max_id=6, **settings), problem, lambda: False), lines


def test_protocol1_servos_are_pinged_id_by_id_where_their_family_is_used():
    bus = FakeBus({1: XM430}, protocol1={4: AX12A, 5: MX28})
    part, lines = scan(bus, "used", used_series=("X", "AX", "MX1"))
    found = part.scan([], expected=3)
    assert found == {1: (2, XM430), 4: (1, AX12A), 5: (1, MX28)}
    assert bus.of("scan") == [("scan", (1, 2, 3, 4, 5, 6))]
    pings = [c[1] for c in bus.of("ping1")]
    # every ID (a Protocol 2.0 servo ignores Protocol 1.0 packets: a 1.0 servo at its ID is found too), then
    # the IDs that answered a few times more (two servos at one ID garble or double every reply)
    assert pings[:6] == [1, 2, 3, 4, 5, 6] and set(pings[6:]) == {4, 5}, pings
    assert lookup(found[4]).name == "AX-12A" and lookup(found[4]).protocol == 1
    assert lookup((2, 9999)) is None


def test_without_a_protocol1_family_no_protocol1_ping_is_sent_while_enough_answer():
    bus = FakeBus({1: XM430}, protocol1={4: AX12A})
    part, _ = scan(bus, "unused", used_series=("X",))
    assert part.scan([], expected=1) == {1: (2, XM430)}
    assert not bus.of("ping1")


def test_too_few_servos_names_the_protocol1_ones_and_their_parameter():
    bus = FakeBus({1: XM430}, protocol1={4: AX12A, 5: AX12A, 6: MX28})
    part, lines = scan(bus, "explain", used_series=("X",))
    with pytest.raises(StartupError, match="found 1 servo"):
        part.scan([], expected=4)
    assert ("ID 4 AX-12A, ID 5 AX-12A: answer(s) Protocol 1.0, family AX, which init/used_servo_series does not "
            "enable: set init/used_servo_series.AX true to drive them") in lines
    assert any("ID 6 MX-28" in line and "init/used_servo_series.MX1 true" in line for line in lines)


def test_a_servo_that_boots_after_the_first_scan_is_found_by_a_later_one():
    """Scans are 100 ms apart (as the C++ handler's): a servo powered up with the computer, still
    booting at the first scan, is found by a later one instead of failing the start-up within a
    few milliseconds of retries."""
    bus = FakeBus({1: XM430, 2: XM430})
    bus.silent = {2}
    booted = threading.Timer(0.15, bus.silent.clear)
    booted.start()
    try:
        part, lines = scan(bus, "boot", retry_times=10)
        assert part.scan([], expected=2) == {1: (2, XM430), 2: (2, XM430)}
    finally:
        booted.cancel()
    assert 2 <= len(bus.of("scan")) < 11 and "scan 1/11 of IDs 1..6 on fake at 57600 bps: 1 servo(s) [1]" in lines
