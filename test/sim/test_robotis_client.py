"""A client written the way the ROBOTIS SDK examples are (module constants, PortHandler,
PacketHandler, GroupSyncWrite/GroupSyncRead on Indirect Data), run unchanged against
``dynamixel_handler_sim`` as it starts with no flags: an XM430-W350 fresh from the box at ID 1,
57600 bps, wire timed. The answers are those the e-Manual predicts for the real servo.
"""

import subprocess
import sys

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, GroupSyncWrite, PacketHandler, PortHandler

# ---- as in the example: control table addresses (XM430-W350 e-Manual) ----
ADDR_TORQUE_ENABLE = 64
ADDR_LED = 65
ADDR_GOAL_POSITION = 116
ADDR_MOVING = 122
ADDR_PRESENT_POSITION = 132
ADDR_INDIRECTADDRESS_FOR_WRITE = 168   # Indirect Address 1..5: goal position (4), LED (1)
ADDR_INDIRECTADDRESS_FOR_READ = 178    # Indirect Address 6..10: moving (1), present position (4)
ADDR_INDIRECTDATA_FOR_WRITE = 224      # Indirect Data 1..5
ADDR_INDIRECTDATA_FOR_READ = 229       # Indirect Data 6..10
LEN_INDIRECTDATA_FOR_WRITE = 5
LEN_INDIRECTDATA_FOR_READ = 5
PROTOCOL_VERSION = 2.0
DXL_ID = 1
BAUDRATE = 57600
TORQUE_ENABLE, TORQUE_DISABLE = 1, 0
DXL_MOVING_STATUS_THRESHOLD = 20
GOALS = (1200, 2900)


def run_example(devicename: str) -> dict:
    port_handler = PortHandler(devicename)
    packet_handler = PacketHandler(PROTOCOL_VERSION)
    group_write = GroupSyncWrite(port_handler, packet_handler, ADDR_INDIRECTDATA_FOR_WRITE, LEN_INDIRECTDATA_FOR_WRITE)
    group_read = GroupSyncRead(port_handler, packet_handler, ADDR_INDIRECTDATA_FOR_READ, LEN_INDIRECTDATA_FOR_READ)
    assert port_handler.openPort() and port_handler.setBaudRate(BAUDRATE)
    seen: dict = {"ping": packet_handler.ping(port_handler, DXL_ID)}

    # Indirect addresses can only be written with torque off
    result, error = packet_handler.write1ByteTxRx(port_handler, DXL_ID, ADDR_TORQUE_ENABLE, TORQUE_DISABLE)
    assert (result, error) == (COMM_SUCCESS, 0)
    write_targets = [ADDR_GOAL_POSITION + k for k in range(4)] + [ADDR_LED]
    read_targets = [ADDR_MOVING] + [ADDR_PRESENT_POSITION + k for k in range(4)]
    for base, targets in ((ADDR_INDIRECTADDRESS_FOR_WRITE, write_targets), (ADDR_INDIRECTADDRESS_FOR_READ, read_targets)):
        for k, target in enumerate(targets):
            result, error = packet_handler.write2ByteTxRx(port_handler, DXL_ID, base + 2 * k, target)
            assert (result, error) == (COMM_SUCCESS, 0)
    result, error = packet_handler.write1ByteTxRx(port_handler, DXL_ID, ADDR_TORQUE_ENABLE, TORQUE_ENABLE)
    assert (result, error) == (COMM_SUCCESS, 0)
    assert group_read.addParam(DXL_ID)

    seen["arrived"] = []
    for goal in GOALS:
        group_write.addParam(DXL_ID, list(goal.to_bytes(4, "little")) + [1])
        assert group_write.txPacket() == COMM_SUCCESS
        group_write.clearParam()
        for _ in range(2000):  # the example loops until the goal is reached
            assert group_read.txRxPacket() == COMM_SUCCESS
            assert group_read.isAvailable(DXL_ID, ADDR_INDIRECTDATA_FOR_READ, 1)
            moving = group_read.getData(DXL_ID, ADDR_INDIRECTDATA_FOR_READ, 1)
            present = group_read.getData(DXL_ID, ADDR_INDIRECTDATA_FOR_READ + 1, 4)
            if abs(goal - present) <= DXL_MOVING_STATUS_THRESHOLD and not moving:
                break
        seen["arrived"].append((moving, present))
    seen["led"] = packet_handler.read1ByteTxRx(port_handler, DXL_ID, ADDR_LED)
    seen["goal"] = packet_handler.read4ByteTxRx(port_handler, DXL_ID, ADDR_GOAL_POSITION)
    packet_handler.write1ByteTxRx(port_handler, DXL_ID, ADDR_TORQUE_ENABLE, TORQUE_DISABLE)
    port_handler.closePort()
    return seen


def test_robotis_style_indirect_example_against_the_default_simulator():
    sim = subprocess.Popen([sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--servo", "1:XM430-W350"],
                           stdout=subprocess.PIPE, stdin=subprocess.PIPE, text=True)
    try:
        seen = run_example(sim.stdout.readline().strip())
    finally:
        sim.terminate()
        sim.wait(10)
    assert seen["ping"] == (1020, COMM_SUCCESS, 0)          # model number of the XM430-W350
    for goal, (moving, present) in zip(GOALS, seen["arrived"]):
        assert moving == 0 and abs(present - goal) <= DXL_MOVING_STATUS_THRESHOLD
    assert seen["led"] == (1, COMM_SUCCESS, 0)              # the LED byte went through Indirect Data 5
    assert seen["goal"] == (GOALS[-1], COMM_SUCCESS, 0)
