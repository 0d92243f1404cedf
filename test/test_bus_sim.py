"""The bus layer end to end against the virtual Dynamixel bus (a real peer on a pty).

Every value read is compared with the simulator's registers, every value written is
checked in the simulator, so these show what a user would see on hardware.
"""
from __future__ import annotations

import pytest

from dynamixel_handler.bus import BusError, DynamixelBus
from dynamixel_handler.bus.ops import Action, BulkRead, Ping, Read, RegWrite, SyncRead, Write
from dynamixel_handler.sim import VirtualBus

SERVOS = {1: 1020, 2: 1120, 3: 2020, 4: 54024}  # XM430-W350, XM540-W270, PH54-200-S500-R, H54-200-S500-R
P_SERVO = 3


@pytest.fixture
def sim():
    with VirtualBus(servos=dict(SERVOS), seed=7) as virtual:
        yield virtual


@pytest.fixture
def bus(sim):
    dxl = DynamixelBus(sim.path, retry_num=5, retry_interval_ms=1.0)
    dxl.open()
    yield dxl
    dxl.close()


def item(sim, dxl_id, name):
    return sim.servo(dxl_id).model.item(name)


def raw(sim, dxl_id, name):
    it = item(sim, dxl_id, name)
    return sim.servo(dxl_id).read_raw(it.address, it.size)


def test_scan_finds_every_model(sim, bus):
    assert bus.scan(range(0, 11)) == SERVOS
    assert [entry.ids for entry in sim.log if entry.instruction == 0x01] == [(0xFE,)]


def test_ping_and_read_match_the_registers(sim, bus):
    for dxl_id, model in SERVOS.items():
        assert bus.execute(Ping(dxl_id, protocol=2)).value == model
        it = item(sim, dxl_id, "present_temperature")
        assert bus.execute(Read(dxl_id, it.address, it.size, protocol=2)).value == raw(sim, dxl_id, "present_temperature")
    assert bus.execute(Ping(9, retries=0, protocol=2)).value is None


# defect 1 ---------------------------------------------------------------------------
def test_p_series_goal_that_contains_ff_ff_fd_arrives_intact(sim, bus):
    goal = item(sim, P_SERVO, "goal_position")
    assert sim.servo(P_SERVO).read("min_position_limit") <= -131073
    assert bus.execute(Write(P_SERVO, goal.address, (-131073).to_bytes(4, "little", signed=True), protocol=2)).value is True
    assert sim.servo(P_SERVO).read("goal_position") == -131073

    assert bus.execute(bus.prepare_sync_write(goal.address, 4, {P_SERVO: (-131073 - 256).to_bytes(4, "little", signed=True)},
                                              protocol=2)).value
    assert bus.execute(Ping(P_SERVO, protocol=2)).value == SERVOS[P_SERVO]  # sync write has no reply: sync with the peer
    assert sim.servo(P_SERVO).read("goal_position") == -131073 - 256


# defect 2 ---------------------------------------------------------------------------
def test_fast_bulk_read_with_ids_equal_to_lengths(sim, bus):
    """ID 2 is requested right after a 2-byte read (the SDK's ``param.index(2)`` lands on that
    length byte) and ID 2's data bytes equal IDs too."""
    position = item(sim, 2, "present_position")
    sim.servo(2).write("homing_offset", 0x0103)  # present position bytes now look like IDs
    requests = {1: (0, 2), 2: (position.address, 4), 3: (item(sim, 3, "present_temperature").address, 1)}
    got = bus.execute(BulkRead(requests, fast=True, protocol=2)).value
    assert got[1] == (1020).to_bytes(2, "little")
    assert got[2] == raw(sim, 2, "present_position")
    assert got[3] == raw(sim, 3, "present_temperature")
    entry = sim.log[-1]
    assert entry.instruction == 0x9A and entry.ids == (1, 2, 3)


def test_fast_sync_read_matches_plain_sync_read(sim, bus):
    temperature = item(sim, 1, "present_input_voltage")
    plain = bus.execute(SyncRead(temperature.address, 2, [1, 2], protocol=2)).value
    fast = bus.execute(SyncRead(temperature.address, 2, [1, 2], fast=True, protocol=2)).value
    assert plain == fast == {1: raw(sim, 1, "present_input_voltage"), 2: raw(sim, 2, "present_input_voltage")}


def test_repeated_sync_reads_check_their_ids_whatever_was_read_before(sim, bus):
    """Sync read packets are kept between loops; a key that merely equals an earlier one (1.0 == 1)
    still gets its IDs checked, and each ID list, tuple or not, gets its own packet."""
    voltage = item(sim, 1, "present_input_voltage")
    want = {1: raw(sim, 1, "present_input_voltage"), 2: raw(sim, 2, "present_input_voltage")}
    for _ in range(3):
        assert bus.execute(SyncRead(voltage.address, 2, (1, 2), protocol=2)).value == want
    with pytest.raises(ValueError, match="invalid Dynamixel ID 1.0"):
        bus.execute(SyncRead(voltage.address, 2, (1.0, 2), protocol=2)).value
    with pytest.raises(ValueError, match="invalid Dynamixel ID 300"):
        bus.execute(SyncRead(voltage.address, 2, (300,), protocol=2)).value
    assert bus.execute(SyncRead(voltage.address, 2, [2, 1, 2], protocol=2)).value == want
    assert bus.execute(SyncRead(voltage.address, 2, (2,), protocol=2)).value == {2: want[2]}
    reads = [entry.ids for entry in sim.log if entry.instruction == 0x82]
    assert reads == [(1, 2)] * 3 + [(2, 1), (2,)]


# defect 3 ---------------------------------------------------------------------------
def test_reg_write_then_unicast_action_then_read(sim, bus):
    led = item(sim, 1, "led")
    assert bus.execute(RegWrite(1, led.address, b"\x01", protocol=2)).value is True
    assert sim.servo(1).read("led") == 0
    assert bus.execute(Action(1, protocol=2)).value is True
    assert sim.servo(1).read("led") == 1
    model = item(sim, 1, "model_number")
    assert bus.execute(Read(1, model.address, 2, protocol=2)).value == (1020).to_bytes(2, "little")
    assert bus.stats.full_success_rate == 1.0


def test_action_without_registered_write_is_reported(sim, bus):
    refused = bus.execute(Action(2, protocol=2))
    assert refused.value is False and refused.error is not None and refused.error & 0x7F == 2  # instruction error
    assert bus.execute(Ping(2, protocol=2)).value == SERVOS[2]  # and nothing is left over for the next transaction


# defect 4 ---------------------------------------------------------------------------
@pytest.mark.parametrize("silent", [1, 2, 4])
def test_sync_read_with_a_silent_servo_returns_the_others(sim, bus, silent):
    sim.set_silent(silent)
    got = bus.execute(SyncRead(0, 2, [1, 2, 4], protocol=2)).value  # model number: address 0 on every series
    assert got == {i: SERVOS[i].to_bytes(2, "little") for i in (1, 2, 4) if i != silent}
    assert bus.stats.full_successes == 0 and bus.stats.successes == 1


def test_fast_sync_read_keeps_servos_before_a_silent_one(sim, bus):
    sim.set_silent(2)
    voltage = item(sim, 1, "present_input_voltage")
    got = bus.execute(SyncRead(voltage.address, 2, [1, 2, 3], fast=True, protocol=2)).value
    assert got[1] == raw(sim, 1, "present_input_voltage")
    assert 2 not in got


# defect 6 ---------------------------------------------------------------------------
def test_one_ms_latency_timer_waits_briefly_for_a_silent_servo(sim):
    dxl = DynamixelBus(sim.path, baudrate=1000000, latency_timer_ms=1.0, retry_num=0)
    dxl.open()
    sim.set_silent(1)
    assert dxl.execute(Ping(1, protocol=2)).value is None
    assert dxl.timing.last_timeout_ms < 2 * 16 + 2
    dxl.close()


# faults -----------------------------------------------------------------------------
def test_hardware_alert_is_reported_with_the_data(sim, bus):
    sim.set_hardware_error(1, 0x04)  # overheating
    model = item(sim, 1, "model_number")
    got = bus.execute(Read(1, model.address, 2, protocol=2))
    assert got.value == (1020).to_bytes(2, "little") and got.error is not None and got.error & 0x80


def test_noise_crc_errors_and_truncation_are_retried(sim, bus):
    model = item(sim, 1, "model_number")
    sim.inject_garbage(7)
    assert bus.execute(Read(1, model.address, 2, protocol=2)).value == (1020).to_bytes(2, "little")
    sim.truncate_next(1)
    assert bus.execute(Read(1, model.address, 2, protocol=2)).value == (1020).to_bytes(2, "little")
    assert bus.stats.retries >= 1
    sim.crc_error_rate = 0.3
    for _ in range(10):
        assert bus.execute(Read(1, model.address, 2, protocol=2)).value == (1020).to_bytes(2, "little")
    assert bus.stats.crc_errors >= 1


def test_adapter_unplugged_and_plugged_back(tmp_path):
    link = str(tmp_path / "ttyDXL")
    with VirtualBus(servos={1: 1020}, link=link) as sim:
        dxl = DynamixelBus(link, retry_num=1, retry_interval_ms=1.0)
        dxl.open()
        assert dxl.execute(Ping(1, protocol=2)).value == 1020
        sim.vanish()
        assert dxl.execute(Ping(1, protocol=2)).value is None
        assert dxl.execute(SyncRead(132, 4, [1], protocol=2)).value == {}
        assert not dxl.is_open
        with pytest.raises(BusError, match="does not exist"):
            dxl.reopen()
        sim.reappear()
        dxl.reopen()
        assert dxl.execute(Ping(1, protocol=2)).value == 1020
        dxl.close()


def test_the_serial_bus_and_the_dummy_bus_are_the_same_kind_of_bus(sim, bus):
    """The handler talks to either through ServoBus; the dummy bus forwards nothing implicitly."""
    from dynamixel_handler.bus import ServoBus
    from dynamixel_handler.dummy import BusWithDummies, make_dummies

    mixed = BusWithDummies(bus, make_dummies([9], "X"))
    assert isinstance(bus, ServoBus) and isinstance(mixed, ServoBus)
    assert not hasattr(BusWithDummies, "__getattr__")
    assert mixed.device == bus.device and mixed.baudrate == bus.baudrate and mixed.stats is bus.stats
    assert mixed.scan([1, 2, 9]) == {1: 1020, 2: 1120, 9: 1020}
    assert dict(bus.dummies) == {} and list(mixed.dummies) == [9]
    assert mixed.execute(Read(1, 132, 4, protocol=2)).value == sim.servo(1).read_raw(132, 4)
