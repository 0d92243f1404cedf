"""MX-28/64/106 (2.0), XC335-T332 and the RH-P12-RN(A) gripper (and its older RH-P12-RN firmware)
through the real node on the virtual bus: each is recognised with its name, a command in units lands as the pulses the e-Manual's units
give (written out here, not taken from the product's tables), present values come back in units, a
mode change and a limit write work, and what a model lacks reads back as the spec says (NaN, false).
The MX and XC335 take the X topics; the grippers the series-independent ones (status, goal, limit),
in their own modes only.
"""
from __future__ import annotations

import importlib
import math
import shlex
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelGoal, DynamixelLimit, DynamixelStatus

from support.rig import Rig
from support.waits import wait_regs, wait_state


@dataclass(frozen=True)
class Manual:
    """A model's e-Manual facts: name, units per LSB, the zero of its position."""

    name: str
    deg: float          # position, deg per pulse
    zero: int           # pulse of 0 deg
    deg_s: float        # velocity, deg/s per LSB (rpm per LSB x 6)
    ma: float           # current, mA per LSB (NaN: no current sensing)
    modes: tuple[str, ...]
    refused: str        # a mode the model does not have


X_DEG, X_DEG_S = 360.0 / 4096, 0.229 * 6.0
MANUALS = {
    1: Manual("MX-28(2.0)", X_DEG, 2048, X_DEG_S, math.nan, ("velocity", "position"), "current"),
    2: Manual("MX-64(2.0)", X_DEG, 2048, X_DEG_S, 3.36, ("cur_position", "position"), "warp"),
    3: Manual("MX-106(2.0)", X_DEG, 2048, X_DEG_S, 3.36, ("current", "position"), "warp"),
    4: Manual("XC335-T332", X_DEG, 2048, X_DEG_S, 1.0, ("ex_position", "position"), "warp"),
    # RH-P12-RN(A): 1 pulse = 0.088 deg (12-bit encoder over 360 deg), 0 = open; 0.01 rpm; 1 mA
    5: Manual("RH-P12-RN(A)", 360.0 / 4096, 0, 0.01 * 6.0, 1.0, ("current", "cur_position"), "position"),
    # RH-P12-RN (older firmware, the old PRO table): the same stroke, 0.114 rpm, about 4.02 mA
    6: Manual("RH-P12-RN", 360.0 / 4096, 0, 0.114 * 6.0, 4.02, ("current", "cur_position"), "ex_position"),
}
SERVOS = {1: 30, 2: 311, 3: 321, 4: 1700, 5: 35074, 6: 35073}
X_IDS, GRIPPER, OLD_GRIPPER = [1, 2, 3, 4], 5, 6
SERIES = {GRIPPER: "P", OLD_GRIPPER: "Pro"}
MODE = {"current": 0, "velocity": 1, "position": 3, "ex_position": 4, "cur_position": 5, "pwm": 16}


def pulses(value: float, per_lsb: float) -> int:
    return round(value / per_lsb)


@pytest.fixture(scope="module")
def rig():
    r = Rig(SERVOS, "mode_change_interval_sec:=0.0", "pub_ratio/status:=3", "pub_ratio/goal:=3",
            "pub_ratio/limit:=3", "pub_ratio/gain:=3", "pub_ratio/extra.dynamic_items:=3", "pub_ratio/extra.static_items:=3")
    yield r
    assert r.close() == 0


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


@pytest.mark.parametrize("dxl_id", sorted(SERVOS))
def test_recognised_at_start_up_with_its_name(rig, dxl_id):
    assert f"ID {dxl_id}: {MANUALS[dxl_id].name}" in rig.output, rig.output
    rig.wait(lambda: rig.state_of("extra", "model_number", dxl_id) == SERVOS[dxl_id],
             what=f"extra.model_number of ID {dxl_id}")
    assert rig.state_of("extra", "model", dxl_id) == SERIES.get(dxl_id, "X")  # the series


@pytest.mark.parametrize("dxl_id", X_IDS)
def test_x_topic_position_in_degrees_lands_as_raw_goal(rig, dxl_id):
    man = MANUALS[dxl_id]
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[dxl_id], position_deg=[45.0 - 10 * dxl_id]))
    wait_regs(rig, dxl_id, {"operating_mode": MODE["position"],
                            "goal_position": man.zero + pulses(45.0 - 10 * dxl_id, man.deg)})


@pytest.mark.parametrize("dxl_id", [GRIPPER, OLD_GRIPPER])
def test_gripper_closes_to_a_goal_position_with_a_current_limit(rig, dxl_id):
    """The gripper ships in current-based position mode: the series-independent goal topic sets the
    stroke and the current it may use, without a mode change."""
    man = MANUALS[dxl_id]
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[dxl_id], torque=[True]))
    wait_regs(rig, dxl_id, {"torque_enable": 1})
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[dxl_id], position_deg=[60.0], current_ma=[400.0]))
    wait_regs(rig, dxl_id, {"operating_mode": MODE["cur_position"], "goal_position": pulses(60.0, man.deg),
                            "goal_current": pulses(400.0, man.ma)})
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[dxl_id], position_deg=[0.0], current_ma=[150.0]))
    wait_regs(rig, dxl_id, {"goal_position": 0, "goal_current": pulses(150.0, man.ma)})


@pytest.mark.parametrize("dxl_id", sorted(SERVOS))
def test_present_values_come_back_in_units(rig, dxl_id):
    man = MANUALS[dxl_id]
    servo = rig.sim.servo(dxl_id)
    position, velocity = man.zero + 300, -25
    servo.pin("present_position", position)
    servo.pin("present_velocity", velocity)
    has_current = not math.isnan(man.ma)
    if has_current:
        servo.pin("present_current", 120)
    try:
        wait_state(rig, "present", "position_deg", dxl_id, 300 * man.deg, 1e-6)
        wait_state(rig, "present", "velocity_deg_s", dxl_id, velocity * man.deg_s, 1e-6)
        wait_state(rig, "present", "current_ma", dxl_id, 120 * man.ma if has_current else math.nan, 1e-6)
    finally:
        for item in ("present_position", "present_velocity") + (("present_current",) if has_current else ()):
            servo.pin(item, None)


@pytest.mark.parametrize("dxl_id", sorted(SERVOS))
def test_mode_changes_and_a_mode_it_lacks_is_refused(rig, dxl_id):
    man = MANUALS[dxl_id]
    for mode in man.modes:
        rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[dxl_id], mode=[mode]))
        wait_regs(rig, dxl_id, {"operating_mode": MODE[mode]})
        rig.wait(lambda m=mode: rig.state_of("status", "mode", dxl_id) == m, what=f"status.mode of ID {dxl_id}")
    before = reg(rig, dxl_id, "operating_mode")
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[dxl_id], mode=[man.refused]))
    rig.wait_log(f"ID {dxl_id}", man.refused, since=mark)
    assert reg(rig, dxl_id, "operating_mode") == before


@pytest.mark.parametrize("dxl_id", sorted(SERVOS))
def test_limit_write_lands_in_eeprom_units(rig, dxl_id):
    man = MANUALS[dxl_id]
    speed = 20.0 if dxl_id != GRIPPER else 12.0  # deg/s
    if dxl_id == GRIPPER:
        msg = DynamixelLimit(id_list=[dxl_id], velocity_limit_deg_s=[speed], max_position_limit_deg=[90.0])
        expected = {"velocity_limit": pulses(speed, man.deg_s), "max_position_limit": pulses(90.0, man.deg)}
    else:
        msg = DynamixelLimit(id_list=[dxl_id], velocity_limit_deg_s=[speed], temperature_limit_degc=[65.0])
        expected = {"velocity_limit": pulses(speed, man.deg_s), "temperature_limit": 65}
    rig.publish("/dynamixel/command/limit", msg)
    wait_regs(rig, dxl_id, expected)
    wait_state(rig, "limit", "velocity_limit_deg_s", dxl_id, expected["velocity_limit"] * man.deg_s, 1e-6)


def test_what_a_model_lacks_reads_back_as_the_spec_says(rig):
    # MX-28(2.0): no current sensing; no MX has Startup Configuration; the X330 table has no
    # Acceleration Limit; the gripper has no Drive Mode and no PWM Slope
    for group, field in (("goal", "current_ma"), ("limit", "current_limit_ma")):
        wait_state(rig, group, field, 1, math.nan, 0)
    for dxl_id in (2, 3):
        wait_state(rig, "limit", "current_limit_ma", dxl_id, reg(rig, dxl_id, "current_limit") * 3.36, 1e-6)
    for dxl_id in (1, 2, 3):  # MX: Acceleration Limit 32767 x 214.577 rev/min^2 = 21.4577 deg/s^2 each
        wait_state(rig, "limit", "acceleration_limit_deg_ss", dxl_id, 32767 * 21.4577, 1.0)
    wait_state(rig, "limit", "acceleration_limit_deg_ss", 4, math.nan, 0)
    rig.wait(lambda: rig.state_of("extra", "restore_configuration.startup_torque_on", 1) is not None,
             what="extra of ID 1")
    assert rig.state_of("extra", "restore_configuration.startup_torque_on", 1) is False
    assert rig.state_of("extra", "drive_mode.reverse_mode", GRIPPER) is False
    assert math.isnan(rig.state_of("extra", "pwm_slope_percent", GRIPPER))
    # the older RH-P12-RN: no PWM, no Homing Offset, no velocity gains
    wait_state(rig, "present", "pwm_percent", OLD_GRIPPER, math.nan, 0)
    rig.wait(lambda: rig.state_of("gain", "position_p_gain_pulse", OLD_GRIPPER) is not None, what="gains of ID 6")
    assert rig.state_of("gain", "velocity_p_gain_pulse", OLD_GRIPPER) == 0  # uint: 0 where none
    assert rig.state_of("gain", "position_i_gain_pulse", OLD_GRIPPER) == reg(rig, OLD_GRIPPER, "position_i_gain")
    assert math.isnan(rig.state_of("extra", "homing_offset_deg", OLD_GRIPPER))


@pytest.mark.parametrize("dxl_id", [GRIPPER, OLD_GRIPPER])
def test_a_goal_beyond_the_stroke_is_clamped_to_the_position_limit(rig, dxl_id):
    """The gripper refuses a goal position outside its position limits (e-Manual: Limit Error) in
    current-based position mode: the handler clamps it to the limit and says so."""
    limit = reg(rig, dxl_id, "max_position_limit")
    mark = rig.mark()
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[dxl_id], position_deg=[150.0], current_ma=[200.0]))
    rig.wait_log("clamped", f"ID {dxl_id}", since=mark)
    wait_regs(rig, dxl_id, {"goal_position": limit})


def doc_lines() -> list[tuple[str, object]]:
    """The ``ros2 topic pub`` lines of docs/gripper.md as (topic, message)."""
    text = (Path(__file__).resolve().parent.parent / "docs" / "gripper.md").read_text(encoding="utf-8")
    found = []
    for line in text.splitlines():
        if line.startswith("ros2 topic pub"):
            args = [a for a in shlex.split(line)[3:] if not a.startswith("--")]
            package, _, name = args[1].partition("/msg/")
            cls = getattr(importlib.import_module(f"{package}.msg"), name)
            found.append((args[0], cls(**yaml.safe_load(args[2]))))
    return found


def test_gripper_doc_lines():
    """docs/gripper.md's lines close and open a gripper at its factory ID with a current limit."""
    lines = doc_lines()
    assert [topic for topic, _ in lines] == ["/dynamixel/command/status", "/dynamixel/command/goal",
                                             "/dynamixel/command/goal"]
    deg = MANUALS[GRIPPER].deg
    r = Rig({1: SERVOS[GRIPPER]}, "mode_change_interval_sec:=0.0")
    try:
        servo = r.sim.servo(1)
        r.publish(*lines[0])
        wait_regs(r, 1, {"torque_enable": 1, "operating_mode": MODE["cur_position"]})
        for (topic, msg), goal, current in zip(lines[1:], (740, 0), (400, 150)):
            r.publish(topic, msg)
            wait_regs(r, 1, {"goal_position": goal, "goal_current": current})
            assert pulses(msg.position_deg[0], deg) == goal
            r.wait(lambda g=goal: abs(servo.read("present_position") - g) <= 10, what=f"fingers at {goal}")
    finally:
        assert r.close() == 0
