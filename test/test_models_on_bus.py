"""Models beyond the usual four, through the real node on the virtual bus: the PRO "-RA" (advanced
firmware) servos are P series (their commands come on /dynamixel/commands/p), and the L series,
XM335-T323 and XW430-T200 are recognised with their own scales. After a command, the simulated
servo's registers hold the pulses the e-Manual's units give (written out here, not taken from the
product's tables).
"""
from __future__ import annotations

import pytest

from dynamixel_handler_msgs.msg import (
    DynamixelControlPPosition,
    DynamixelControlProPosition,
    DynamixelControlProVelocity,
    DynamixelControlXCurrent,
    DynamixelControlXPosition,
)

from support.rig import Rig
from support.waits import wait_regs

XM335, XW430_T200, H54_RA, L54_S290, L42, XC330_T181 = 1710, 1280, 54025, 38176, 35072, 1210

# ---- e-Manual units per LSB ------------------------------------------------------------------
# H54-200-S500-R(A): 1,003,846 pulses a turn (+-501,923 = +-180 deg), 0.01 rpm, 1 mA.
RA_DEG, RA_DEG_S = 180.0 / 501923, 0.01 * 6.0
# L54-50-S290-R: 207,692 pulses a turn (+-103,846), Goal Velocity 0.00346667 rpm per LSB,
# Goal Torque A = C x 33,000 / 2,048 mA.
L54_DEG, L54_DEG_S = 180.0 / 103846, 0.00346667 * 6.0
# L42-10-S300-R: 4,096 pulses a turn, 0.114 rpm per LSB.
L42_DEG, L42_DEG_S = 360.0 / 4096, 0.114 * 6.0
# XM335-T323 and XC330-T181: 1.0 mA per LSB; X: 4096 a turn, 0 deg at 2048; XW430-T200: 2.69 mA.
X_DEG, X_ZERO = 360.0 / 4096, 2048


def pulses(value: float, per_lsb: float) -> int:
    return round(value / per_lsb)


@pytest.fixture(scope="module")
def rig():
    # the XM335 ships at 1 Mbps (the others at 57600): the bus and the node run at 1 Mbps here
    servos = {1: XM335, 2: XW430_T200, 3: H54_RA, 4: L54_S290, 5: L42, 6: XC330_T181}
    r = Rig(servos, "baudrate:=1000000", "mode_change_interval_sec:=0.0", "pub_ratio/status:=3",
            sim_kwargs={"baudrate": 1_000_000, "wire_timing": False})
    yield r
    assert r.close() == 0


def test_every_model_is_handled_with_its_name(rig):
    for dxl_id, name in ((1, "XM335-T323"), (2, "XW430-T200"), (3, "H54-200-S500-R(A)"),
                         (4, "L54-50-S290-R"), (5, "L42-10-S300-R"), (6, "XC330-T181")):
        assert f"ID {dxl_id}: {name}" in rig.output, rig.output


def test_pro_ra_takes_p_commands_at_its_own_scale(rig):
    rig.publish("/dynamixel/command/p/position_control",
                DynamixelControlPPosition(id_list=[3], position_deg=[45.0], profile_vel_deg_s=[30.0]))
    wait_regs(rig, 3, {"operating_mode": 3, "goal_position": pulses(45.0, RA_DEG),
                       "profile_velocity": pulses(30.0, RA_DEG_S)})


def test_pro_ra_is_not_a_pro_command_target(rig):
    mark = rig.mark()
    rig.publish("/dynamixel/command/pro/position_control",
                DynamixelControlProPosition(id_list=[3], position_deg=[-60.0]))
    rig.wait_log("ID 3", "not PRO", since=mark)
    assert rig.sim.servo(3).read("goal_position") != pulses(-60.0, RA_DEG)


def test_l_series_scales(rig):
    rig.publish("/dynamixel/command/pro/position_control",
                DynamixelControlProPosition(id_list=[4], position_deg=[90.0], velocity_deg_s=[30.0]))
    wait_regs(rig, 4, {"operating_mode": 3, "goal_position": pulses(90.0, L54_DEG),
                       "goal_velocity": pulses(30.0, L54_DEG_S)})
    rig.publish("/dynamixel/command/pro/velocity_control",
                DynamixelControlProVelocity(id_list=[5], velocity_deg_s=[40.0]))
    wait_regs(rig, 5, {"operating_mode": 1, "goal_velocity": pulses(40.0, L42_DEG_S)})


def test_x335_x330_and_xw430_current_and_position(rig):
    rig.publish("/dynamixel/command/x/current_control",
                DynamixelControlXCurrent(id_list=[1, 6], current_ma=[120.0, 80.0]))
    wait_regs(rig, 1, {"operating_mode": 0, "goal_current": 120})
    wait_regs(rig, 6, {"operating_mode": 0, "goal_current": 80})
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[2], position_deg=[-90.0]))
    wait_regs(rig, 2, {"operating_mode": 3, "goal_position": X_ZERO + pulses(-90.0, X_DEG)})
