"""The census (``bus/census.py``): who answers, and which IDs two servos share, against the virtual
bus whose servos at one ID answer as on hardware (equal Return Delay Times garble the replies,
delays far apart give two replies to one ping)."""
from __future__ import annotations

import pytest

from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.bus.census import census
from dynamixel_handler.sim import VirtualBus

XM430, XM540, XL330 = 1020, 1120, 1200
AX12A, MX28 = 12, 29  # Protocol 1.0


@pytest.fixture
def line():
    made = []

    def factory(servos):
        sim = VirtualBus(servos, baudrate=1_000_000, wire_timing=False)
        sim.start()
        bus = DynamixelBus(sim.path, baudrate=1_000_000, retry_num=0)
        bus.open()
        made.append((sim, bus))
        return sim, bus

    yield factory
    for sim, bus in made:
        bus.close()
        sim.close()


@pytest.mark.parametrize("ids", [range(0, 10), range(1, 4)])   # a broadcast ping, and one ping per ID
def test_a_shared_id_is_told_apart_from_the_servos_alone(line, ids):
    _, bus = line([(1, XM430), (3, XM430), (3, XM540), (5, XL330)])
    seen = census(bus, ids, protocol=2)
    assert set(seen.shared) == {3}
    assert seen.found == {i: m for i, m in {1: XM430, 5: XL330}.items() if i in ids}


def test_two_replies_to_one_ping_are_a_shared_id(line):
    sim, bus = line([(1, XM430), (2, XM430), (2, XL330)])
    quick, slow = sim.servos_at(2)
    quick.write("return_delay_time", 0)
    slow.write("return_delay_time", 250)       # 500 us later: a whole second reply
    seen = census(bus, range(0, 10), protocol=2)
    assert set(seen.shared) == {2} and seen.found == {1: XM430}


def test_late_replies_are_no_shared_id(line):
    """Replies 50 ms late (a loaded host, a slow adapter) land in later pings' time, some in the
    pings of an ID where nobody is: that once looked like a second servo there. Only an ID that
    looks shared in every round is."""
    sim, bus = line([(1, XM430), (2, XM430), (2, XM540), (5, XL330)])
    sim.latency_s = 0.05
    seen = census(bus, range(0, 10), protocol=2)
    assert set(seen.shared) == {2} and seen.found == {1: XM430, 5: XL330}


def test_a_clean_bus_costs_one_scan(line):
    _, bus = line([(1, XM430), (2, XM540), (7, XL330)])
    seen = census(bus, range(0, 10), protocol=2)
    assert seen.found == {1: XM430, 2: XM540, 7: XL330} and not seen.shared
    assert bus.stats.packets_sent == 1          # the broadcast ping alone


def test_two_protocol_1_servos_at_one_id_are_a_shared_id(line):
    """Protocol 1.0 has no broadcast ping: each ID is pinged, and an answered one a few times more;
    two AX-12A at ID 3 garble every reply (the node and the set-up tool named neither)."""
    _, bus = line([(1, AX12A), (3, AX12A), (3, AX12A), (5, MX28)])
    seen = census(bus, range(0, 8), protocol=1)
    assert set(seen.shared) == {3} and seen.found == {1: AX12A, 5: MX28}
    assert census(bus, range(0, 8), protocol=2).found == {}  # none of them answers Protocol 2.0
