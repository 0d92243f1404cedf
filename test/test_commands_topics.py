"""Every command topic and field, through real topics against the virtual bus: after a command the
simulated servo's registers hold the pulses the e-Manual scales give, and the published state
converges to the command in physical units.

Expected pulses are computed here from the e-Manual's unit per LSB (written out below), not with
the product's unit module, so a wrong scale in the product fails these tests.
"""
from __future__ import annotations

import math

import pytest

from dynamixel_handler.ros.lean import RAW_ENV
from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsP,
    DxlCommandsPro,
    DxlCommandsX,
    DynamixelControlPCurrent,
    DynamixelControlPExtendedPosition,
    DynamixelControlPPosition,
    DynamixelControlPPwm,
    DynamixelControlProCurrent,
    DynamixelControlProExtendedPosition,
    DynamixelControlProPosition,
    DynamixelControlProVelocity,
    DynamixelControlPVelocity,
    DynamixelControlXCurrent,
    DynamixelControlXCurrentBasePosition,
    DynamixelControlXExtendedPosition,
    DynamixelControlXPosition,
    DynamixelControlXPwm,
    DynamixelControlXVelocity,
    DynamixelExtra,
    DynamixelGain,
    DynamixelGoal,
    DynamixelStatus,
)

from support.rig import PRO, X540, P, Rig, X
from support.waits import shown, wait_regs, wait_state

# ---- e-Manual units per LSB ------------------------------------------------------------------
# X (XM430-W350, XM540-W270): 4096 pulses a turn, 0 deg at 2048; 0.229 rpm; 214.577 rev/min^2;
# 2.69 mA; 885 = 100 % PWM.
X_DEG, X_ZERO = 360.0 / 4096, 2048
X_DEG_S = 0.229 * 6.0             # rpm -> deg/s
X_DEG_SS = 214.577 * 360 / 3600   # rev/min^2 -> deg/s^2
X_MA = 2.69
X_PWM = 100.0 / 885
# P (PH54-200-S500-R): +-501,923 pulses = +-180 deg; 0.01 rpm; 1 rev/min^2; 1 mA; 2009 = 100 % PWM.
P_DEG = 180.0 / 501923
P_DEG_S = 0.01 * 6.0
P_DEG_SS = 1.0 * 360 / 3600
P_MA = 1.0
P_PWM = 100.0 / 2009
# Pro (H54-200-S500-R): +-250,961 pulses = +-180 deg; 0.00199234 rpm; goal torque 16.11328 mA;
# goal acceleration 58,000 rev/min^2 at the motor, i.e. 58000 / 501.923 (gear ratio) at the output.
PRO_DEG = 180.0 / 250961
PRO_DEG_S = 0.00199234 * 6.0
PRO_MA = 16.11328
PRO_DEG_SS = 58000.0 / 501.923 * 360 / 3600

MODE = {"current": 0, "velocity": 1, "position": 3, "ex_position": 4, "cur_position": 5, "pwm": 16}


def x_pos(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


def pulses(value: float, per_lsb: float) -> int:
    return round(value / per_lsb)


@pytest.fixture(scope="module", params=["raw CDR", "rclpy objects"])
def rig(request):
    """Run twice: commands decoded by the node's own CDR reader, and by rclpy (its fallback)."""
    env = {RAW_ENV: "0"} if request.param == "rclpy objects" else None
    r = Rig({1: X, 2: X540, 3: P, 4: PRO}, "mode_change_interval_sec:=0.0", "pub_ratio/status:=3",
            "pub_ratio/goal:=3", "pub_ratio/gain:=3", "pub_ratio/limit:=5", "pub_ratio/extra.dynamic_items:=5",
            "pub_ratio/extra.static_items:=5", env=env)
    if env:
        r.wait_log("rclpy message objects")
    yield r
    assert r.close() == 0


def near(value, target: float, tol: float) -> bool:
    return value is not None and not math.isnan(value) and abs(value - target) <= tol


def wait_debug(rig: Rig, dxl_id: int, key: str, target: float, tol: float, timeout: float = 15.0) -> None:
    try:
        rig.wait(lambda: near(rig.debug_of(dxl_id)[key], target, tol), timeout=timeout,
                 what=f"ID {dxl_id} {key} -> {target} (last {rig.debug_of(dxl_id)[key]})")
    except AssertionError as exc:
        raise AssertionError(f"{exc}\n{shown(rig, dxl_id)}") from None


def wait_mode(rig: Rig, dxl_id: int, mode: str) -> None:
    wait_regs(rig, dxl_id, {"operating_mode": MODE[mode]})
    rig.wait(lambda: rig.debug_of(dxl_id)["mode"] == mode, what=f"ID {dxl_id} published mode {mode}")


# ============================================================================ X control topics
def test_x_pwm_current_and_velocity_control(rig):
    rig.publish("/dynamixel/command/x/pwm_control", DynamixelControlXPwm(id_list=[1, 2], pwm_percent=[40.0, -20.0]))
    wait_mode(rig, 1, "pwm")
    wait_mode(rig, 2, "pwm")
    wait_regs(rig, 1, {"goal_pwm": pulses(40.0, X_PWM)})
    wait_regs(rig, 2, {"goal_pwm": pulses(-20.0, X_PWM)})
    wait_state(rig, "present", "pwm_percent", 1, 40.0, tol=X_PWM)
    wait_state(rig, "present", "pwm_percent", 2, -20.0, tol=X_PWM)
    wait_state(rig, "goal", "pwm_percent", 1, 40.0, tol=X_PWM)

    rig.publish("/dynamixel/command/x/current_control",
                DynamixelControlXCurrent(id_list=[1, 2], current_ma=[100.0, -200.0]))
    wait_mode(rig, 1, "current")
    wait_regs(rig, 1, {"goal_current": pulses(100.0, X_MA)})
    wait_regs(rig, 2, {"goal_current": pulses(-200.0, X_MA), "operating_mode": MODE["current"]})
    wait_debug(rig, 1, "current", 100.0, X_MA)
    wait_debug(rig, 2, "current", -200.0, X_MA)
    wait_debug(rig, 2, "goal_current", -200.0, X_MA)

    rig.publish("/dynamixel/command/x/velocity_control",
                DynamixelControlXVelocity(id_list=[1, 2], velocity_deg_s=[60.0, -45.0], profile_acc_deg_ss=[600.0, 1200.0]))
    wait_mode(rig, 1, "velocity")
    wait_regs(rig, 1, {"goal_velocity": pulses(60.0, X_DEG_S), "profile_acceleration": pulses(600.0, X_DEG_SS)})
    wait_regs(rig, 2, {"goal_velocity": pulses(-45.0, X_DEG_S), "profile_acceleration": pulses(1200.0, X_DEG_SS),
                       "operating_mode": MODE["velocity"]})
    wait_debug(rig, 1, "velocity", 60.0, X_DEG_S)
    wait_debug(rig, 2, "velocity", -45.0, X_DEG_S)
    wait_state(rig, "goal", "profile_acc_deg_ss", 2, 1200.0, tol=X_DEG_SS)


def test_x_position_extended_and_current_based_position_control(rig):
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2], position_deg=[90.0, -45.0], profile_vel_deg_s=[200.0, 150.0],
                                          profile_acc_deg_ss=[1000.0, 2000.0]))
    wait_mode(rig, 1, "position")
    wait_regs(rig, 1, {"goal_position": x_pos(90.0), "profile_velocity": pulses(200.0, X_DEG_S),
                       "profile_acceleration": pulses(1000.0, X_DEG_SS)})
    wait_regs(rig, 2, {"goal_position": x_pos(-45.0), "profile_velocity": pulses(150.0, X_DEG_S),
                       "profile_acceleration": pulses(2000.0, X_DEG_SS), "operating_mode": MODE["position"]})
    wait_debug(rig, 1, "position", 90.0, 0.2)
    wait_debug(rig, 2, "position", -45.0, 0.2)
    wait_state(rig, "goal", "profile_vel_deg_s", 1, 200.0, tol=X_DEG_S)

    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[1, 2], position_deg=[30.0, -10.0], rotation=[2.0, -1.0],
                                                  profile_vel_deg_s=[1000.0, 1000.0], profile_acc_deg_ss=[5000.0, 5000.0]))
    wait_mode(rig, 1, "ex_position")
    wait_regs(rig, 1, {"goal_position": x_pos(750.0), "profile_acceleration": pulses(5000.0, X_DEG_SS)})
    wait_regs(rig, 2, {"goal_position": x_pos(-370.0), "operating_mode": MODE["ex_position"]})
    wait_debug(rig, 1, "position", 750.0, 0.2)
    wait_debug(rig, 2, "position", -370.0, 0.2)

    rig.publish("/dynamixel/command/x/current_base_position_control",
                DynamixelControlXCurrentBasePosition(id_list=[1, 2], current_ma=[500.0, 300.0], position_deg=[0.0, 20.0],
                                                     rotation=[1.0, 0.0], profile_vel_deg_s=[250.0, 150.0],
                                                     profile_acc_deg_ss=[3000.0, 4000.0]))
    wait_mode(rig, 2, "cur_position")
    wait_regs(rig, 1, {"operating_mode": MODE["cur_position"], "goal_current": pulses(500.0, X_MA),
                       "goal_position": x_pos(360.0), "profile_velocity": pulses(250.0, X_DEG_S),
                       "profile_acceleration": pulses(3000.0, X_DEG_SS)})
    wait_regs(rig, 2, {"goal_current": pulses(300.0, X_MA), "goal_position": x_pos(20.0),
                       "profile_velocity": pulses(150.0, X_DEG_S), "profile_acceleration": pulses(4000.0, X_DEG_SS)})
    wait_debug(rig, 1, "position", 360.0, 0.2)
    wait_debug(rig, 2, "position", 20.0, 0.2)
    wait_debug(rig, 1, "goal_current", 500.0, X_MA)


def test_extended_position_rotation_alone_ends_at_432_deg(rig):
    # from 0 deg: rotation 1.2 alone is 1.2 turns = 432 deg
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[2], position_deg=[0.0], profile_vel_deg_s=[1000.0]))
    wait_mode(rig, 2, "position")
    wait_debug(rig, 2, "position", 0.0, 0.2)
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[2], rotation=[1.2]))
    wait_mode(rig, 2, "ex_position")
    wait_regs(rig, 2, {"goal_position": x_pos(432.0)})
    wait_debug(rig, 2, "position", 432.0, 0.2)
    assert rig.debug_of(2)["goal_position"] == pytest.approx(432.0, abs=X_DEG)


# ============================================================================ P control topics
def test_p_control_topics(rig):
    rig.publish("/dynamixel/command/p/pwm_control", DynamixelControlPPwm(id_list=[3], pwm_percent=[25.0]))
    wait_mode(rig, 3, "pwm")
    wait_regs(rig, 3, {"goal_pwm": pulses(25.0, P_PWM)})
    wait_state(rig, "present", "pwm_percent", 3, 25.0, tol=P_PWM)

    rig.publish("/dynamixel/command/p/current_control", DynamixelControlPCurrent(id_list=[3], current_ma=[300.0]))
    wait_mode(rig, 3, "current")
    wait_regs(rig, 3, {"goal_current": pulses(300.0, P_MA)})
    wait_debug(rig, 3, "current", 300.0, P_MA)

    rig.publish("/dynamixel/command/p/velocity_control",
                DynamixelControlPVelocity(id_list=[3], current_ma=[1000.0], velocity_deg_s=[30.0],
                                          profile_acc_deg_ss=[500.0]))
    wait_mode(rig, 3, "velocity")
    wait_regs(rig, 3, {"goal_current": pulses(1000.0, P_MA), "goal_velocity": pulses(30.0, P_DEG_S),
                       "profile_acceleration": pulses(500.0, P_DEG_SS)})
    wait_debug(rig, 3, "velocity", 30.0, P_DEG_S)

    rig.publish("/dynamixel/command/p/position_control",
                DynamixelControlPPosition(id_list=[3], current_ma=[2000.0], velocity_deg_s=[100.0], position_deg=[45.0],
                                          profile_vel_deg_s=[120.0], profile_acc_deg_ss=[800.0]))
    wait_mode(rig, 3, "position")
    wait_regs(rig, 3, {"goal_current": pulses(2000.0, P_MA), "goal_velocity": pulses(100.0, P_DEG_S),
                       "goal_position": pulses(45.0, P_DEG), "profile_velocity": pulses(120.0, P_DEG_S),
                       "profile_acceleration": pulses(800.0, P_DEG_SS)})
    wait_debug(rig, 3, "position", 45.0, 0.01)

    rig.publish("/dynamixel/command/p/extended_position_control",
                DynamixelControlPExtendedPosition(id_list=[3], current_ma=[1500.0], velocity_deg_s=[90.0],
                                                  position_deg=[10.0], rotation=[1.0], profile_vel_deg_s=[170.0],
                                                  profile_acc_deg_ss=[900.0]))
    wait_mode(rig, 3, "ex_position")
    wait_regs(rig, 3, {"goal_current": pulses(1500.0, P_MA), "goal_velocity": pulses(90.0, P_DEG_S),
                       "goal_position": pulses(370.0, P_DEG), "profile_velocity": pulses(170.0, P_DEG_S),
                       "profile_acceleration": pulses(900.0, P_DEG_SS)})
    wait_debug(rig, 3, "position", 370.0, 0.01)


def test_p_goal_whose_pulses_contain_the_header_bytes_arrives_exactly(rig):
    goal = -131073  # little endian FF FF FD FF: the header pattern Protocol 2.0 must byte-stuff
    assert b"\xff\xff\xfd" in goal.to_bytes(4, "little", signed=True)
    rig.publish("/dynamixel/command/p/position_control",
                DynamixelControlPPosition(id_list=[3], position_deg=[goal * P_DEG]))
    wait_mode(rig, 3, "position")
    wait_regs(rig, 3, {"goal_position": goal})
    wait_debug(rig, 3, "position", goal * P_DEG, 0.01)
    wait_regs(rig, 3, {"present_position": goal})


# ============================================================================ Pro control topics
def test_pro_control_topics(rig):
    rig.publish("/dynamixel/command/pro/current_control", DynamixelControlProCurrent(id_list=[4], current_ma=[200.0]))
    wait_mode(rig, 4, "current")
    wait_regs(rig, 4, {"goal_current": pulses(200.0, PRO_MA)})
    wait_debug(rig, 4, "current", 200.0, PRO_MA)

    rig.publish("/dynamixel/command/pro/velocity_control",
                DynamixelControlProVelocity(id_list=[4], current_ma=[500.0], velocity_deg_s=[20.0],
                                            acceleration_deg_ss=[1000.0]))
    wait_mode(rig, 4, "velocity")
    wait_regs(rig, 4, {"goal_current": pulses(500.0, PRO_MA), "goal_velocity": pulses(20.0, PRO_DEG_S),
                       "profile_acceleration": pulses(1000.0, PRO_DEG_SS)})
    wait_debug(rig, 4, "velocity", 20.0, 0.05)

    rig.publish("/dynamixel/command/pro/position_control",
                DynamixelControlProPosition(id_list=[4], current_ma=[800.0], acceleration_deg_ss=[2000.0],
                                            velocity_deg_s=[90.0], position_deg=[-30.0]))
    wait_mode(rig, 4, "position")
    # old Pro: the speed of a position move is its Goal Velocity
    wait_regs(rig, 4, {"goal_current": pulses(800.0, PRO_MA), "profile_acceleration": pulses(2000.0, PRO_DEG_SS),
                       "goal_velocity": pulses(90.0, PRO_DEG_S), "goal_position": pulses(-30.0, PRO_DEG)})
    wait_debug(rig, 4, "position", -30.0, 0.01)

    rig.publish("/dynamixel/command/pro/extended_position_control",
                DynamixelControlProExtendedPosition(id_list=[4], current_ma=[600.0], acceleration_deg_ss=[3000.0],
                                                    velocity_deg_s=[180.0], position_deg=[15.0], rotation=[-1.0]))
    wait_mode(rig, 4, "ex_position")
    wait_regs(rig, 4, {"goal_current": pulses(600.0, PRO_MA), "profile_acceleration": pulses(3000.0, PRO_DEG_SS),
                       "goal_velocity": pulses(180.0, PRO_DEG_S), "goal_position": pulses(-345.0, PRO_DEG)})
    wait_debug(rig, 4, "position", -345.0, 0.01)


# ============================================================================ bundles
def test_commands_x_p_pro_bundles(rig):
    x = DxlCommandsX()
    x.position_control = DynamixelControlXPosition(id_list=[1], position_deg=[45.0], profile_vel_deg_s=[1000.0])
    x.velocity_control = DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[30.0])
    x.gain = DynamixelGain(id_list=[1], position_p_gain_pulse=[900])
    x.extra = DynamixelExtra(id_list=[2])
    x.extra.led.red_percent = [100.0]
    rig.publish("/dynamixel/commands/x", x)
    p = DxlCommandsP()
    p.current_control = DynamixelControlPCurrent(id_list=[3], current_ma=[150.0])
    p.gain = DynamixelGain(id_list=[3], velocity_p_gain_pulse=[700])
    rig.publish("/dynamixel/commands/p", p)
    pro = DxlCommandsPro()
    pro.position_control = DynamixelControlProPosition(id_list=[4], position_deg=[20.0], velocity_deg_s=[150.0])
    pro.gain = DynamixelGain(id_list=[4], velocity_i_gain_pulse=[33])
    rig.publish("/dynamixel/commands/pro", pro)

    wait_mode(rig, 1, "position")
    wait_regs(rig, 1, {"goal_position": x_pos(45.0), "position_p_gain": 900})
    wait_mode(rig, 2, "velocity")
    wait_regs(rig, 2, {"goal_velocity": pulses(30.0, X_DEG_S), "led": 1})
    wait_mode(rig, 3, "current")
    wait_regs(rig, 3, {"goal_current": pulses(150.0, P_MA), "velocity_p_gain": 700})
    wait_mode(rig, 4, "position")
    wait_regs(rig, 4, {"goal_position": pulses(20.0, PRO_DEG), "velocity_i_gain": 33})
    wait_debug(rig, 1, "position", 45.0, 0.2)
    wait_debug(rig, 2, "velocity", 30.0, X_DEG_S)
    wait_debug(rig, 3, "current", 150.0, P_MA)
    wait_debug(rig, 4, "position", 20.0, 0.01)
    wait_state(rig, "gain", "position_p_gain_pulse", 1, 900)
    wait_state(rig, "gain", "velocity_i_gain_pulse", 4, 33)
    wait_state(rig, "extra", "led.red_percent", 2, 100.0)


def test_commands_all_writes_goals_without_changing_modes(rig):
    # the modes first (whatever ran before): 1 position, 2 velocity, 3 current, 4 position
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 2, 3, 4],
                                                              mode=["position", "velocity", "current", "position"]))
    for dxl_id, mode in ((1, "position"), (2, "velocity"), (3, "current"), (4, "position")):
        wait_mode(rig, dxl_id, mode)
    before = {i: rig.sim.servo(i).read("operating_mode") for i in (1, 2, 3, 4)}
    assert before == {1: MODE["position"], 2: MODE["velocity"], 3: MODE["current"], 4: MODE["position"]}
    msg = DxlCommandsAll()
    msg.goal = DynamixelGoal(id_list=[1, 2, 3, 4], position_deg=[-60.0, 0.0, 0.0, -10.0],
                             velocity_deg_s=[0.0, -40.0, 0.0, 120.0], current_ma=[0.0, 0.0, -250.0, 0.0])
    msg.status = DynamixelStatus(id_list=[2], torque=[True])
    msg.gain = DynamixelGain(id_list=[2], velocity_i_gain_pulse=[1500])
    rig.publish("/dynamixel/commands/all", msg)
    wait_regs(rig, 1, {"goal_position": x_pos(-60.0), "goal_velocity": 0, "goal_current": 0})
    wait_regs(rig, 2, {"goal_velocity": pulses(-40.0, X_DEG_S), "goal_position": x_pos(0.0), "velocity_i_gain": 1500})
    wait_regs(rig, 3, {"goal_current": pulses(-250.0, P_MA), "goal_position": 0})
    wait_regs(rig, 4, {"goal_position": pulses(-10.0, PRO_DEG), "goal_velocity": pulses(120.0, PRO_DEG_S)})
    wait_debug(rig, 1, "position", -60.0, 0.2)
    wait_debug(rig, 2, "velocity", -40.0, X_DEG_S)
    wait_debug(rig, 3, "current", -250.0, P_MA)
    wait_debug(rig, 4, "position", -10.0, 0.01)
    assert {i: rig.sim.servo(i).read("operating_mode") for i in (1, 2, 3, 4)} == before
    assert [rig.debug_of(i)["mode"] for i in (1, 2, 3, 4)] == ["position", "velocity", "current", "position"]


# ============================================================================ command/goal, gain, status
def test_command_goal_every_field(rig):
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[2], position_deg=[0.0]))
    rig.publish("/dynamixel/command/p/position_control", DynamixelControlPPosition(id_list=[3], position_deg=[0.0]))
    wait_mode(rig, 2, "position")
    wait_mode(rig, 3, "position")
    wait_regs(rig, 2, {"goal_position": x_pos(0.0)})  # taken: the goal below comes after it
    wait_regs(rig, 3, {"goal_position": 0})
    rig.publish("/dynamixel/command/goal",
                DynamixelGoal(id_list=[2, 3], pwm_percent=[45.0, 60.0], current_ma=[400.0, 700.0],
                              velocity_deg_s=[20.0, 40.0], position_deg=[-30.0, 12.0], profile_vel_deg_s=[100.0, 80.0],
                              profile_acc_deg_ss=[700.0, 900.0]))
    wait_regs(rig, 2, {"goal_pwm": pulses(45.0, X_PWM), "goal_current": pulses(400.0, X_MA),
                       "goal_velocity": pulses(20.0, X_DEG_S), "goal_position": x_pos(-30.0),
                       "profile_velocity": pulses(100.0, X_DEG_S), "profile_acceleration": pulses(700.0, X_DEG_SS)})
    wait_regs(rig, 3, {"goal_pwm": pulses(60.0, P_PWM), "goal_current": pulses(700.0, P_MA),
                       "goal_velocity": pulses(40.0, P_DEG_S), "goal_position": pulses(12.0, P_DEG),
                       "profile_velocity": pulses(80.0, P_DEG_S), "profile_acceleration": pulses(900.0, P_DEG_SS)})
    for field, value, tol in (("pwm_percent", 45.0, X_PWM), ("current_ma", 400.0, X_MA),
                              ("velocity_deg_s", 20.0, X_DEG_S), ("position_deg", -30.0, X_DEG),
                              ("profile_vel_deg_s", 100.0, X_DEG_S), ("profile_acc_deg_ss", 700.0, X_DEG_SS)):
        wait_state(rig, "goal", field, 2, value, tol=tol)
    for field, value, tol in (("pwm_percent", 60.0, P_PWM), ("current_ma", 700.0, P_MA),
                              ("velocity_deg_s", 40.0, P_DEG_S), ("position_deg", 12.0, P_DEG),
                              ("profile_vel_deg_s", 80.0, P_DEG_S), ("profile_acc_deg_ss", 900.0, P_DEG_SS)):
        wait_state(rig, "goal", field, 3, value, tol=tol)
    wait_debug(rig, 2, "position", -30.0, 0.2)
    wait_debug(rig, 3, "position", 12.0, 0.01)


GAINS = ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain", "position_p_gain",
         "feedforward_2nd_gain", "feedforward_1st_gain")


def test_command_gain_every_field(rig):
    values = {2: [1000, 200, 10, 20, 1200, 30, 40], 3: [20, 650, 1, 2, 40, 3, 4]}
    before = {i: [rig.sim.servo(i).read(g) for g in GAINS] for i in (2, 3)}
    pro = {g: rig.sim.servo(4).read(g) for g in ("velocity_i_gain", "velocity_p_gain", "position_p_gain")}
    msg = DynamixelGain(id_list=[2, 3])
    for k, gain in enumerate(GAINS):
        setattr(msg, f"{gain}_pulse", [values[2][k], values[3][k]])
    rig.publish("/dynamixel/command/gain", msg)
    for dxl_id in (2, 3):
        wait_regs(rig, dxl_id, dict(zip(GAINS, values[dxl_id])))
        for gain, value in zip(GAINS, values[dxl_id]):
            wait_state(rig, "gain", f"{gain}_pulse", dxl_id, value)
    # the old Pro has velocity I/P and position P only: those are written, the rest is refused by name
    mark = rig.mark()
    rig.publish("/dynamixel/command/gain", DynamixelGain(id_list=[4], velocity_i_gain_pulse=[45], velocity_p_gain_pulse=[66],
                                                         position_p_gain_pulse=[77], position_d_gain_pulse=[5]))
    wait_regs(rig, 4, {"velocity_i_gain": 45, "velocity_p_gain": 66, "position_p_gain": 77})
    rig.wait_log("ID 4", "position_d_gain", since=mark)
    wait_state(rig, "gain", "position_p_gain_pulse", 4, 77)
    # the gains as they were, for the tests after this one (a low P gain makes a slow servo)
    restore = DynamixelGain(id_list=[2, 3])
    for k, gain in enumerate(GAINS):
        setattr(restore, f"{gain}_pulse", [before[2][k], before[3][k]])
    rig.publish("/dynamixel/command/gain", restore)
    rig.publish("/dynamixel/command/gain", DynamixelGain(id_list=[4], **{f"{g}_pulse": [v] for g, v in pro.items()}))
    for dxl_id in (2, 3):
        wait_regs(rig, dxl_id, dict(zip(GAINS, before[dxl_id])))
    wait_regs(rig, 4, pro)


def test_command_status_torque_mode_and_ping(rig):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 3], torque=[False, False]))
    wait_regs(rig, 1, {"torque_enable": 0})
    wait_regs(rig, 3, {"torque_enable": 0})
    rig.wait(lambda: not rig.debug_of(1)["torque"] and not rig.debug_of(3)["torque"], what="torque off published")
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 3], mode=["velocity", "ex_position"]))
    wait_mode(rig, 1, "velocity")
    wait_mode(rig, 3, "ex_position")
    assert rig.sim.servo(1).read("torque_enable") == 0  # torque stays as it was
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 3], torque=[True, True]))
    wait_regs(rig, 1, {"torque_enable": 1, "goal_velocity": 0})  # safe torque on: velocity goal neutral
    wait_regs(rig, 3, {"torque_enable": 1})
    assert rig.sim.servo(3).read("goal_position") == rig.sim.servo(3).read("present_position")
    rig.wait(lambda: rig.debug_of(1)["torque"] and rig.debug_of(3)["torque"], what="torque on published")

    # ping false removes an ID from the handled set, ping true adds it back; neither is warned about
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], ping=[False]))
    rig.wait(lambda: list(rig.debug[-1].status.id_list) == [1, 3, 4], what="ID 2 removed")
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[2], ping=[True]))
    rig.wait(lambda: list(rig.debug[-1].status.id_list) == [1, 2, 3, 4], what="ID 2 added back")
    mode = next(name for name, value in MODE.items() if value == rig.sim.servo(2).read("operating_mode"))
    rig.wait(lambda: rig.debug_of(2)["ping"] and rig.debug_of(2)["mode"] == mode, what=f"ID 2 read again ({mode})")
    rig.wait_log("ID 2: removed", since=mark)
    rig.wait_log("ID 2: XM540-W270 added", since=mark)
    assert rig.warnings_since(mark, about=[2]) == []


# ============================================================================ command/extra
def test_command_extra_every_writable_field(rig):
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[0.0]))
    wait_mode(rig, 1, "position")
    msg = DynamixelExtra(id_list=[1, 3])
    msg.return_delay_time_us = [100.0, 20.0]
    msg.shadow_id = [7, 9]
    msg.homing_offset_deg = [90.0, 45.0]
    msg.moving_threshold_deg_s = [13.74, 3.0]
    msg.bus_watchdog_ms = [1000.0, 1200.0]
    msg.drive_mode.reverse_mode = [True, False]
    msg.drive_mode.profile_configuration = ["time_based", "velocity_based"]
    msg.drive_mode.torque_on_by_goal_update = [True, True]
    msg.restore_configuration.ram_restore = [True, False]
    msg.restore_configuration.startup_torque_on = [False, True]
    msg.shutdown.overload_error = [True, False]
    msg.shutdown.electrical_shock_error = [False, True]
    msg.shutdown.motor_encoder_error = [True, False]
    msg.shutdown.motor_hall_sensor_error = [False, True]
    msg.shutdown.overheating_error = [True, True]
    msg.shutdown.input_voltage_error = [False, True]
    msg.led.red_percent = [100.0, 40.0]
    msg.led.green_percent = [0.0, 20.0]
    msg.led.blue_percent = [0.0, 80.0]
    mark = rig.mark()
    rig.publish("/dynamixel/command/extra", msg)
    # e-Manual: return delay 2 us, watchdog 20 ms per LSB; X homing offset 360/4096 deg without the
    # 2048 centre; drive mode bit 0 reverse, bit 2 time-based profile, bit 3 torque on by goal update;
    # startup configuration bit 0 torque on, bit 1 RAM restore; shutdown bits 0 voltage, 1 hall,
    # 2 overheating, 3 encoder, 4 electrical shock, 5 overload; P LEDs 0..255.
    wait_regs(rig, 1, {"return_delay_time": 50, "secondary_id": 7, "homing_offset": 1024,
                       "moving_threshold": pulses(13.74, X_DEG_S), "bus_watchdog": 50, "drive_mode": 0b1101,
                       "startup_configuration": 0b10, "shutdown": 0b101100, "led": 1})
    wait_regs(rig, 3, {"return_delay_time": 10, "secondary_id": 9, "homing_offset": pulses(45.0, P_DEG),
                       "moving_threshold": pulses(3.0, P_DEG_S), "bus_watchdog": 60, "drive_mode": 0b1000,
                       "startup_configuration": 0b01, "shutdown": 0b010111, "led_red": 102, "led_green": 51,
                       "led_blue": 204})
    # EEPROM writes happen with torque off, and torque comes back
    wait_regs(rig, 1, {"torque_enable": 1})
    wait_regs(rig, 3, {"torque_enable": 1})
    for field, value in (("return_delay_time_us", 100.0), ("homing_offset_deg", 90.0), ("shadow_id", 7),
                         ("drive_mode.reverse_mode", True), ("drive_mode.profile_configuration", "time_based"),
                         ("restore_configuration.ram_restore", True), ("shutdown.overload_error", True),
                         ("shutdown.electrical_shock_error", False), ("bus_watchdog_ms", 1000.0)):
        wait_state(rig, "extra", field, 1, value, tol=1e-6)
    wait_state(rig, "extra", "led.blue_percent", 3, 80.0, tol=0.2)
    wait_state(rig, "extra", "restore_configuration.startup_torque_on", 3, True)
    # X has one LED, driven by red: the other colours are refused by name, nothing else is warned about
    warnings = rig.warnings_since(mark)
    assert len(warnings) == 2 and all("ID 1 (XM430-W350) has no" in w for w in warnings), warnings
    assert "green LED" in warnings[0] + warnings[1] and "blue LED" in warnings[0] + warnings[1]

    # read-only fields are refused by name; the writable ones in the same message still apply
    mark = rig.mark()
    bad = DynamixelExtra(id_list=[1], model=["XM430-W350"], firmware_version=[99], homing_offset_deg=[0.0])
    bad.drive_mode.reverse_mode = [False]
    bad.drive_mode.profile_configuration = ["velocity_based"]
    bad.drive_mode.torque_on_by_goal_update = [False]
    rig.publish("/dynamixel/command/extra", bad)
    wait_regs(rig, 1, {"homing_offset": 0, "drive_mode": 0, "firmware_version": 48})
    rig.wait_log("'model' is read-only", since=mark)
    rig.wait_log("'firmware_version' is read-only", since=mark)

    # reboot: RAM back to the defaults (LED off), and with startup torque on, torque comes up by itself
    n = len(rig.sim.log)
    rig.publish("/dynamixel/command/extra", DynamixelExtra(id_list=[3], reboot=[True]))
    rig.wait(lambda: any(e.instruction == 0x08 and e.ids == (3,) for e in rig.sim.log[n:]), what="reboot of ID 3")
    wait_regs(rig, 3, {"led_red": 0, "led_blue": 0, "torque_enable": 1})
    wait_state(rig, "extra", "led.blue_percent", 3, 0.0, tol=0.01)
