"""Limits (EEPROM) through /dynamixel/command/limit and the bundles: every field reaches the
register with the e-Manual's scale, the write happens with torque off and torque comes back as it
was, the published limits follow, and goals beyond the new limits are clamped to them.
"""
from __future__ import annotations

import pytest

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsP,
    DynamixelControlPPosition,
    DynamixelControlXPosition,
    DynamixelLimit,
    DynamixelShortcut,
)

from support.rig import PRO, X540, P, Rig, X

# e-Manual units per LSB: X 4096 pulses a turn centred on 2048, 0.229 rpm, 2.69 mA, 885 = 100 %;
# P PH54-200-S500-R +-501,923 = +-180 deg, 0.01 rpm, 1 rev/min^2, 1 mA, 2009 = 100 %;
# Pro H54-200-S500-R +-250,961 = +-180 deg, 0.00199234 rpm, 16.11328 mA, 58,000 rev/min^2 at the
# motor through the 501.923 gear. Every series: 0.1 V, 1 degC.
X_DEG, X_ZERO, X_DEG_S, X_MA, X_PWM = 360.0 / 4096, 2048, 0.229 * 6.0, 2.69, 100.0 / 885
P_DEG, P_DEG_S, P_DEG_SS, P_PWM = 180.0 / 501923, 0.01 * 6.0, 0.1, 100.0 / 2009
PRO_DEG, PRO_DEG_S, PRO_MA, PRO_DEG_SS = 180.0 / 250961, 0.00199234 * 6.0, 16.11328, 58000.0 / 501.923 / 10
TORQUE_ENABLE = {2: 64, 3: 512, 4: 562}  # e-Manual addresses (X, P, old Pro)
WRITE = 0x03

FIELDS = ("temperature_limit_degc", "max_voltage_limit_v", "min_voltage_limit_v", "pwm_limit_percent",
          "current_limit_ma", "acceleration_limit_deg_ss", "velocity_limit_deg_s", "max_position_limit_deg",
          "min_position_limit_deg")
ITEMS = ("temperature_limit", "max_voltage_limit", "min_voltage_limit", "pwm_limit", "current_limit",
         "acceleration_limit", "velocity_limit", "max_position_limit", "min_position_limit")
# ID -> the command's value per field, and the pulses each must give (None: the model lacks it)
VALUES = {
    2: [75.0, 15.0, 10.0, 80.0, 3000.0, 900.0, 150.0, 170.0, -170.0],
    3: [70.0, 30.0, 16.0, 90.0, 10000.0, 900.0, 120.0, 150.0, -150.0],
    4: [72.0, 35.0, 18.0, 50.0, 3000.0, 5000.0, 150.0, 120.0, -120.0],
}
PULSES = {
    2: [75, 150, 100, round(80.0 / X_PWM), round(3000.0 / X_MA), None, round(150.0 / X_DEG_S),
        X_ZERO + round(170.0 / X_DEG), X_ZERO + round(-170.0 / X_DEG)],
    3: [70, 300, 160, round(90.0 / P_PWM), 10000, round(900.0 / P_DEG_SS), round(120.0 / P_DEG_S),
        round(150.0 / P_DEG), round(-150.0 / P_DEG)],
    4: [72, 350, 180, None, round(3000.0 / PRO_MA), round(5000.0 / PRO_DEG_SS), round(150.0 / PRO_DEG_S),
        round(120.0 / PRO_DEG), round(-120.0 / PRO_DEG)],
}

# ID -> physical units per LSB of each field (the published value is within half of it)
LSB = {
    2: [1.0, 0.1, 0.1, X_PWM, X_MA, None, X_DEG_S, X_DEG, X_DEG],
    3: [1.0, 0.1, 0.1, P_PWM, 1.0, P_DEG_SS, P_DEG_S, P_DEG, P_DEG],
    4: [1.0, 0.1, 0.1, None, PRO_MA, PRO_DEG_SS, PRO_DEG_S, PRO_DEG, PRO_DEG],
}


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: P, 4: PRO}, "mode_change_interval_sec:=0.0", "pub_ratio/limit:=3",
            "pub_ratio/status:=3")
    yield r
    assert r.close() == 0


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def wait_reg(rig: Rig, dxl_id: int, item: str, value: int, timeout: float = 10.0) -> None:
    rig.wait(lambda: reg(rig, dxl_id, item) == value, timeout=timeout,
             what=f"ID {dxl_id} {item} == {value} (holds {reg(rig, dxl_id, item)})")


def test_every_limit_field_with_torque_off_for_the_write(rig):
    for i in (2, 3, 4):
        assert reg(rig, i, "torque_enable") == 1  # torque_auto_enable
    n_log, n_refused = len(rig.sim.log), len(rig.sim.refused)
    mark = rig.mark()
    msg = DynamixelLimit(id_list=[2, 3, 4])
    for k, field in enumerate(FIELDS):
        setattr(msg, field, [VALUES[i][k] for i in (2, 3, 4)])
    rig.publish("/dynamixel/command/limit", msg)
    for i in (2, 3, 4):
        for item, pulses in zip(ITEMS, PULSES[i]):
            if pulses is not None:
                wait_reg(rig, i, item, pulses)
    # the models without an item are told by name
    rig.wait_log("ID 2", "has no acceleration_limit", since=mark)
    rig.wait_log("ID 4", "has no pwm_limit", since=mark)
    # torque back on; no write was refused by a servo (EEPROM needs torque off)
    for i in (2, 3, 4):
        wait_reg(rig, i, "torque_enable", 1)
    assert list(rig.sim.refused)[n_refused:] == []
    for i in (2, 3, 4):
        torque = [e.params[-1] for e in rig.sim.log[n_log:]
                  if e.instruction == WRITE and e.ids == (i,) and e.address == TORQUE_ENABLE[i]]
        assert torque[:1] == [0] and torque[-1] == 1, torque
    # the published limits follow, in physical units
    for i in (2, 3, 4):
        for field, value, lsb in zip(FIELDS, VALUES[i], LSB[i]):
            if lsb is None:
                continue
            rig.wait(lambda i=i, f=field, v=value, t=lsb / 2 + 1e-6: _near(rig.state_of("limit", f, i), v, t), timeout=10,
                     what=f"ID {i} limit.{field} -> {value} (last {rig.state_of('limit', field, i)})")


def _near(got, want: float, tolerance: float) -> bool:
    """``got`` (None until a limit message with the servo has come) within ``tolerance`` of ``want``."""
    return got is not None and abs(got - want) <= tolerance


def test_goals_beyond_the_new_limits_are_clamped_to_them(rig):
    # the position and current limits of the test above (the same values: whichever runs first writes them)
    k_max, k_min, k_cur = ITEMS.index("max_position_limit"), ITEMS.index("min_position_limit"), ITEMS.index("current_limit")
    rig.publish("/dynamixel/command/limit", DynamixelLimit(
        id_list=[2, 3], max_position_limit_deg=[VALUES[i][k_max] for i in (2, 3)],
        min_position_limit_deg=[VALUES[i][k_min] for i in (2, 3)], current_limit_ma=[VALUES[i][k_cur] for i in (2, 3)]))
    for i in (2, 3):
        for k in (k_max, k_min, k_cur):
            wait_reg(rig, i, ITEMS[k], PULSES[i][k])
        wait_reg(rig, i, "torque_enable", 1)
    mark = rig.mark()
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[2], position_deg=[179.0], profile_vel_deg_s=[500.0]))
    rig.publish("/dynamixel/command/p/position_control",
                DynamixelControlPPosition(id_list=[3], position_deg=[-179.0], current_ma=[20000.0]))
    wait_reg(rig, 2, "goal_position", PULSES[2][7])
    # X: Profile Velocity takes its register range (0..32767), not the Velocity Limit
    wait_reg(rig, 2, "profile_velocity", round(500.0 / X_DEG_S))
    wait_reg(rig, 3, "goal_position", PULSES[3][8])
    wait_reg(rig, 3, "goal_current", PULSES[3][4])
    rig.wait_log("ID 2", "'position_deg' = 179", "clamped to 169.9", since=mark)
    rig.wait_log("ID 3", "'current_ma' = 20000", "clamped to 10000", since=mark)
    top = (PULSES[2][7] - X_ZERO) * X_DEG
    rig.wait(lambda: abs(rig.debug_of(2)["position"] - top) < 0.1, timeout=15, what="ID 2 at its new max position limit")


def test_torque_stays_off_when_it_was_off_and_bundles_write_limits(rig):
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[1]))
    wait_reg(rig, 1, "torque_enable", 0)
    bundle = DxlCommandsAll()
    bundle.limit = DynamixelLimit(id_list=[1], temperature_limit_degc=[65.0], velocity_limit_deg_s=[137.4])
    rig.publish("/dynamixel/commands/all", bundle)
    wait_reg(rig, 1, "temperature_limit", 65)
    wait_reg(rig, 1, "velocity_limit", 100)
    assert reg(rig, 1, "torque_enable") == 0
    p = DxlCommandsP()
    p.limit = DynamixelLimit(id_list=[3], temperature_limit_degc=[66.0])
    rig.publish("/dynamixel/commands/p", p)
    wait_reg(rig, 3, "temperature_limit", 66)
    wait_reg(rig, 3, "torque_enable", 1)


def test_bad_limits_are_refused_by_name_and_the_rest_applies(rig):
    lo, hi = reg(rig, 2, "min_position_limit"), reg(rig, 2, "max_position_limit")
    current = reg(rig, 2, "current_limit")
    mark = rig.mark()
    rig.publish("/dynamixel/command/limit",
                DynamixelLimit(id_list=[2], min_position_limit_deg=[30.0], max_position_limit_deg=[-30.0],
                               current_limit_ma=[-5.0], temperature_limit_degc=[61.0]))
    wait_reg(rig, 2, "temperature_limit", 61)
    rig.wait_log("ID 2", "min position limit above max", since=mark)
    rig.wait_log("ID 2", "'current_limit_ma'", "negative", since=mark)
    assert (reg(rig, 2, "min_position_limit"), reg(rig, 2, "max_position_limit"), reg(rig, 2, "current_limit")) \
        == (lo, hi, current)
