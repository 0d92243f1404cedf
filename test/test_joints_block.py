"""The ``joints`` block (``dynamixel_handler/joints/block.py``) as ``validate`` reads it: each kind of
joint's map (reduction, offset, direction; a prismatic joint's stroke; a mimic joint), its soft
limits, and one clear line for each entry that cannot be right. ROS-free."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dynamixel_handler.config import ConfigError, defaults, validate
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.joints import DEG, read_joints
from dynamixel_handler.servo.table import ServoTable

XM430 = 1020


def config(**block):
    v = defaults()
    v.update({f"joints.{k}": x for k, x in block.items()})
    return validate(v)


def problem(**block) -> str:
    try:
        config(**block)
    except ConfigError as err:
        return str(err)
    return ""


def test_a_reduction_an_offset_and_a_direction_make_the_joint_s_map():
    ros = config(**{"shoulder.id": 1, "shoulder.reduction": 2.0, "shoulder.offset": 0.1, "shoulder.direction": -1}).settings.ros
    assert ros.joint_state_use  # a joints block publishes joint_states and takes joint commands
    shoulder = ros.joints.joint("shoulder")
    # joint = offset + direction x servo / reduction: servo 0 is the joint at 0.1 rad
    assert shoulder.to_joint(0.0) == pytest.approx(0.1)
    assert shoulder.to_servo_deg(1.1) == pytest.approx(-2.0 / DEG)  # 1 rad of joint: 2 rad of servo, flipped
    assert shoulder.to_joint(shoulder.to_servo_deg(0.7)) == pytest.approx(0.7)


def test_a_prismatic_joint_is_a_linear_map_to_metres_and_a_mimic_follows_it():
    ros = config(**{"gripper.id": 5, "gripper.type": "prismatic", "gripper.stroke": [0.0, 0.04],
                    "gripper.servo_deg": [0.0, 100.0], "finger.mimic": "gripper", "finger.multiplier": -1.0,
                    "finger.offset": 0.01}).settings.ros
    gripper = ros.joints.joint("gripper")
    assert gripper.prismatic and gripper.to_servo_deg(0.02) == pytest.approx(50.0)
    table = ServoTable()
    model = model_by_number(XM430)
    table.add(5, model)
    table.set_value("present_position", 5, model.position_zero_pulse + round(25.0 / model.position_deg_per_pulse))
    reading = read_joints(ros.joints, table)
    assert reading.names == ["gripper", "finger"]
    assert reading.position_rad[0] == pytest.approx(0.01, abs=1e-4)       # 25 deg of 100: a quarter of 4 cm
    assert reading.position_rad[1] == pytest.approx(-0.01 + 0.01, abs=1e-4)
    assert math.isnan(reading.effort_a[1])  # a mimic joint's effort is not known


def test_the_joint_state_parameters_and_the_block_together():
    v = defaults()
    v.update({"joint_state.use": True, "joint_state.names": ["pan"], "joint_state.ids": [1],
              "joints.tilt.id": 2, "joints.tilt.limits.position": [-0.5, 0.5]})
    joints = validate(v).settings.ros.joints
    assert joints.names == ("pan", "tilt") and joints.ids == (1, 2)
    assert joints.joint("tilt").clamped(0.9) == 0.5 and joints.joint("pan").clamped(9.0) == 9.0
    v["joints.pan.id"] = 3
    with pytest.raises(ConfigError, match="joint 'pan' is both in joint_state.names and in the joints block"):
        validate(v)


@pytest.mark.parametrize("block, line", [
    ({"a.id": 1, "a.gear": 2.0}, "joints.a.gear: unknown key for a revolute joint (known: direction, id, limits.effort"),
    ({"a.id": 1, "b.id": 1}, "joints.b.id = 1: servo 1 already drives joint 'a': one joint per servo"),
    ({"a.mimic": "nobody"}, "joints.a.mimic = 'nobody': no such joint driven by a servo (known: none)"),
    ({"a.coupled": [6, 7]}, "joints.a.row: 0 factors for 2 servos: one per servo of coupled"),
    ({"a.id": 1, "a.reduction": 0.0}, "joints.a.reduction = 0: servo turns per joint turn, above 0"),
    ({"a.id": 1, "a.reduction": math.nan}, "joints.a.reduction = nan: a finite number"),
    ({"a.id": 1, "a.direction": 2}, "joints.a.direction = 2: 1 or -1"),
    ({"a.id": 1.5}, "joints.a.id = 1.5: a whole number"),
    ({"a.id": True}, "joints.a.id = True: a whole number"),
    ({"a.id": 253}, "joints.a.id = 253: servo IDs are 0..252"),
    ({"a.reduction": 2.0}, "joints.a: no id"),
    ({"a.id": 1, "a.type": "spherical"}, "joints.a.type = 'spherical': revolute or prismatic"),
    ({"a.id": 1, "a.type": "prismatic", "a.stroke": [0.0, 0.04]}, "joints.a: a prismatic joint needs stroke"),
    ({"a.id": 1, "a.type": "prismatic", "a.stroke": [0.0, 0.04], "a.servo_deg": [5.0, 5.0]},
     "need two different values each"),
    ({"a.id": 1, "a.type": "prismatic", "a.stroke": [0.0, 0.04], "a.servo_deg": [0.0, 9.0], "a.reduction": 2.0},
     "joints.a.reduction: unknown key for a prismatic joint"),
    ({"a.id": 1, "a.limits.position": [1.0, -1.0]}, "the lower limit first, below the upper one"),
    ({"a.id": 1, "a.limits.position": [0.0]}, "two numbers"),
    ({"a.id": 1, "a.limits.velocity": -2.0}, "joints.a.limits.velocity = -2: above 0"),
    ({"a.id": 1, "a.offset": 1e308}, "joints.a.offset = 1e+308: out of range"),
    ({"a.id": 1, "b.mimic": "a", "b.scale": 2.0}, "joints.b.scale: unknown key for a mimic joint"),
    ({"a": 1}, "the joints block holds one map per joint"),
])
def test_an_entry_that_cannot_be_right_is_one_line(block, line):
    assert line in problem(**block)


def test_limits_in_joint_units_clamp_and_the_servo_sees_them_through_the_map():
    joint = config(**{"elbow.id": 3, "elbow.reduction": 3.0, "elbow.limits.position": [-1.0, 2.0],
                      "elbow.limits.velocity": 1.5, "elbow.limits.effort": 0.8}).settings.ros.joints.joint("elbow")
    assert [joint.clamped(p) for p in (-5.0, 0.5, 5.0)] == [-1.0, 0.5, 2.0]
    assert joint.velocity_limit == 1.5 and joint.effort_limit == 0.8
    assert np.isclose(joint.to_servo_deg(2.0), 3.0 * 2.0 / DEG)


def test_a_joint_of_several_servos_is_their_mean_each_with_its_direction():
    joints = config(**{"elbow.ids": [3, 4], "elbow.directions": [1, -1], "elbow.reduction": 2.0,
                       "elbow.disagreement_deg": 3.0}).settings.ros.joints
    elbow = joints.joint("elbow")
    assert elbow.servo_ids == (3, 4) and elbow.disagreement == pytest.approx(3.0 * DEG)
    assert joints.servo_ids == (3, 4)
    with pytest.raises(ValueError, match="joint elbow is driven by servos 3 and 4: name one of them"):
        joints.id_of("elbow")
    table = ServoTable()
    model = model_by_number(XM430)
    for dxl_id, deg in ((3, 20.0), (4, -24.0)):
        table.add(dxl_id, model)
        table.set_value("present_position", dxl_id, model.position_zero_pulse + round(deg / model.position_deg_per_pulse))
    reading = read_joints(joints, table)
    assert reading.names == ["elbow"]
    assert reading.position_rad[0] == pytest.approx(22.0 / 2.0 * DEG, abs=1e-3)  # the mean of 10 and 12 deg


@pytest.mark.parametrize("block, line", [
    ({"a.ids": [3]}, "joints.a.ids = [3]: two or more different servo IDs"),
    ({"a.ids": [3, 3]}, "joints.a.ids = [3, 3]: two or more different servo IDs"),
    ({"a.ids": [3, 4], "a.directions": [1]}, "joints.a.directions: 1 values for 2 servos"),
    ({"a.ids": [3, 4], "a.directions": [1, 0]}, "joints.a.directions = 0: 1 or -1"),
    ({"a.ids": [3, 4], "a.id": 5}, "joints.a.id: unknown key for a joint of several servos"),
    ({"a.id": 4, "b.ids": [3, 4]}, "joints.b.ids = [3, 4]: servo 4 already drives joint 'a'"),
])
def test_a_joint_of_several_servos_that_cannot_be_right_is_one_line(block, line):
    assert line in problem(**block)


def test_a_coupled_set_is_solved_as_a_matrix_and_read_as_its_rows():
    joints = config(**{"wrist_pitch.coupled": [6, 7], "wrist_pitch.row": [0.5, 0.5],
                       "wrist_roll.coupled": [7, 6], "wrist_roll.row": [-0.5, 0.5]}).settings.ros.joints
    pitch, roll = joints.joint("wrist_pitch"), joints.joint("wrist_roll")
    assert pitch.coupling is roll.coupling or pitch.coupling == roll.coupling
    coupling = pitch.coupling
    assert coupling.servo_ids == (6, 7) and coupling.names == ("wrist_pitch", "wrist_roll")
    assert coupling.rows == ((0.5, 0.5), (0.5, -0.5))  # the roll's row put in the set's servo order
    assert np.allclose(coupling.servos_rad([0.2, 0.1]), [0.3, 0.1])  # pitch + roll, pitch - roll
    table = ServoTable()
    model = model_by_number(XM430)
    for dxl_id, deg in ((6, 20.0), (7, 10.0)):
        table.add(dxl_id, model)
        table.set_value("present_position", dxl_id, model.position_zero_pulse + round(deg / model.position_deg_per_pulse))
    reading = read_joints(joints, table)
    at = dict(zip(reading.names, reading.position_rad))
    assert at["wrist_pitch"] == pytest.approx(15.0 * DEG, abs=1e-3) and at["wrist_roll"] == pytest.approx(5.0 * DEG, abs=1e-3)
    assert all(math.isnan(e) for e in reading.effort_a)


@pytest.mark.parametrize("block, line", [
    ({"a.coupled": [6, 7], "a.row": [0.5, 0.5]}, "joints.a.coupled = [6, 7]: 2 servos need 2 joints naming them, 1 do (a)"),
    ({"a.coupled": [6, 7], "a.row": [0.5, 0.5], "b.coupled": [6, 7], "b.row": [1.0, 1.0]},
     "joints a, b: their rows [[0.5, 0.5], [1.0, 1.0]] cannot be inverted"),
    ({"a.coupled": [6, 7], "a.row": [0.5]}, "joints.a.row: 1 factors for 2 servos"),
    ({"a.coupled": [6], "a.row": [0.5]}, "joints.a.coupled = [6]: two or more different servo IDs"),
    ({"a.coupled": [6, 7], "a.row": [0.5, 0.5], "a.id": 3}, "joints.a.id: unknown key for a joint of a coupled set"),
    ({"a.coupled": [6, 7], "a.row": [0.5, 0.5], "b.coupled": [6, 7], "b.row": [0.5, -0.5], "c.id": 7},
     "servo 7 already drives joint"),
])
def test_a_coupled_set_that_cannot_be_right_is_one_line(block, line):
    assert line in problem(**block)
