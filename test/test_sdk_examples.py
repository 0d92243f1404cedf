"""ROBOTIS's own Protocol 2.0 examples (DynamixelSDK ``python/tests/protocol2_0``: ping, read_write,
sync_read_write) against the virtual bus: the same ``dynamixel_sdk`` calls in the same order, with the
addresses and defaults of their X_SERIES block (two MX-28(2.0) here) and of their XL320 block, and
what the examples expect to see: the model number from a ping, each goal position reached within
their moving threshold. Only the device path differs from a run on hardware, and the reply wait
(``PatientPort``): the virtual bus answers from a thread of the test process, which a loaded host can
hold back longer than the SDK's 16 ms latency allowance, and dynamixel_sdk 4.1.0's read4ByteTxRx
then raises IndexError on the cut reply instead of reporting it.

X_SERIES block: 57600 bps, IDs 1 and 2, Torque Enable 64 (1 byte), Goal Position 116 and Present
Position 132 (4 bytes), goals 0 and 4095. XL320 block: 1 Mbps, Torque Enable 24, Goal Position 30
and Present Position 37 (2 bytes), goals 0 and 1023. Both: moving threshold 20 pulses.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import pytest
from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, GroupSyncWrite, PacketHandler, PortHandler

from dynamixel_handler.control_table import known_models
from dynamixel_handler.sim import VirtualBus

from support.sdk import PatientPort

pytestmark = pytest.mark.sim

MX_28, XL_320 = 30, 350
MOVING_THRESHOLD = 20
MOVE_TIMEOUT_S = 20.0  # the examples wait as long as it takes; a stuck servo fails here instead


@dataclass(frozen=True)
class Block:
    """One model block of the examples."""

    model: int
    baudrate: int
    torque: int
    goal: int
    present: int
    width: int        # bytes of the position items
    low: int
    high: int


X_SERIES = Block(MX_28, 57600, 64, 116, 132, 4, 0, 4095)
XL320 = Block(XL_320, 1_000_000, 24, 30, 37, 2, 0, 1023)

xl320_known = pytest.mark.skipif(XL_320 not in {m.number for m in known_models()},
                                 reason="the XL-320 (model 350) is not a known model of the control table yet")


def bus_with(block: Block, ids: tuple[int, ...]) -> tuple[VirtualBus, str]:
    """Servos as unboxed (their factory baud rate), replies timed as on the wire; the device path."""
    bus = VirtualBus({dxl_id: block.model for dxl_id in ids})
    return bus, bus.start()


def opened(device: str, block: Block) -> tuple[PortHandler, PacketHandler]:
    port, packet = PatientPort(device), PacketHandler(2.0)
    assert port.openPort(), "openPort"
    assert port.setBaudRate(block.baudrate), "setBaudRate"
    return port, packet


def write_goal(packet: PacketHandler, port: PortHandler, block: Block, dxl_id: int, goal: int) -> None:
    write = packet.write4ByteTxRx if block.width == 4 else packet.write2ByteTxRx
    result, error = write(port, dxl_id, block.goal, goal)
    assert (result, error) == (COMM_SUCCESS, 0), packet.getTxRxResult(result)


def read_present(packet: PacketHandler, port: PortHandler, block: Block, dxl_id: int) -> int | None:
    read = packet.read4ByteTxRx if block.width == 4 else packet.read2ByteTxRx
    value, result, error = read(port, dxl_id, block.present)
    return value if result == COMM_SUCCESS and error == 0 else None


def torque(packet: PacketHandler, port: PortHandler, block: Block, dxl_id: int, on: bool) -> None:
    result, error = packet.write1ByteTxRx(port, dxl_id, block.torque, 1 if on else 0)
    assert (result, error) == (COMM_SUCCESS, 0), packet.getTxRxResult(result)


def little_endian(value: int, width: int) -> list[int]:
    return list(int(value).to_bytes(width, "little"))


# ---------------------------------------------------------------------------------------- ping
@pytest.mark.parametrize("block", [X_SERIES, pytest.param(XL320, marks=xl320_known)], ids=["X_SERIES", "XL320"])
def test_ping_answers_with_the_model_number(block):
    bus, device = bus_with(block, (1,))
    try:
        port, packet = opened(device, block)
        model_number, result, error = packet.ping(port, 1)
        assert (result, error) == (COMM_SUCCESS, 0), packet.getTxRxResult(result)
        assert model_number == block.model
        port.closePort()
    finally:
        bus.close()


# ---------------------------------------------------------------------------------- read_write
@pytest.mark.parametrize("block", [X_SERIES, pytest.param(XL320, marks=xl320_known)], ids=["X_SERIES", "XL320"])
def test_read_write_reaches_each_goal(block):
    bus, device = bus_with(block, (1,))
    try:
        port, packet = opened(device, block)
        torque(packet, port, block, 1, True)
        for goal in (block.low, block.high, block.low):
            write_goal(packet, port, block, 1, goal)
            deadline = time.monotonic() + MOVE_TIMEOUT_S
            while True:  # as the example: read the present position until within the threshold
                present = read_present(packet, port, block, 1)
                if present is not None and abs(goal - present) <= MOVING_THRESHOLD:
                    break
                assert time.monotonic() < deadline, f"goal {goal} not reached: present {present}"
        torque(packet, port, block, 1, False)
        assert bus.servo(1).read("torque_enable") == 0
        port.closePort()
    finally:
        bus.close()


# ----------------------------------------------------------------------------- sync_read_write
@pytest.mark.parametrize("block", [X_SERIES, pytest.param(XL320, marks=xl320_known)], ids=["X_SERIES", "XL320"])
def test_sync_read_write_moves_two_servos(block):
    bus, device = bus_with(block, (1, 2))
    try:
        port, packet = opened(device, block)
        sync_write = GroupSyncWrite(port, packet, block.goal, block.width)
        sync_read = GroupSyncRead(port, packet, block.present, block.width)
        for dxl_id in (1, 2):
            torque(packet, port, block, dxl_id, True)
            assert sync_read.addParam(dxl_id)
        for goal in (block.high, block.low):
            for dxl_id in (1, 2):
                assert sync_write.addParam(dxl_id, little_endian(goal, block.width))
            assert sync_write.txPacket() == COMM_SUCCESS
            sync_write.clearParam()
            landed = time.monotonic() + 2.0  # a sync write has no reply: the bus takes it meanwhile
            while [bus.servo(i).read("goal_position") for i in (1, 2)] != [goal, goal]:
                assert time.monotonic() < landed, f"goal {goal} not written to both"
                time.sleep(0.01)
            deadline = time.monotonic() + MOVE_TIMEOUT_S
            while True:  # as the example: sync read until both are within the threshold
                result = sync_read.txRxPacket()
                if result == COMM_SUCCESS and all(sync_read.isAvailable(i, block.present, block.width) for i in (1, 2)):
                    present = [sync_read.getData(i, block.present, block.width) for i in (1, 2)]
                    if all(abs(goal - p) <= MOVING_THRESHOLD for p in present):
                        break
                assert time.monotonic() < deadline, f"goal {goal} not reached by both"
        sync_read.clearParam()
        for dxl_id in (1, 2):
            torque(packet, port, block, dxl_id, False)
        port.closePort()
    finally:
        bus.close()
