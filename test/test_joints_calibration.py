"""Joint offsets measured from outside (``dynamixel_handler/joints/calibration.py``): the zeros a
measurement gives each kind of joint, the requests refused before anything changes, and the file
they are kept in, written and read back (a file that cannot be right stops the start-up). The
service through the node: ``test_joints_calibration_node.py``. ROS-free."""
from __future__ import annotations

import math
from dataclasses import replace

import pytest

from dynamixel_handler.config import ConfigError, defaults, validate
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.joints import DEG, LiveJoints, read_joints
from dynamixel_handler.joints.calibration import Calibration, load, offsets_yaml

from support.joint_tables import table_at

BLOCK = {"shoulder.id": 1, "shoulder.reduction": 2.0, "shoulder.offset": 0.1, "shoulder.direction": -1,
         "gripper.id": 2, "gripper.type": "prismatic", "gripper.stroke": [0.0, 0.04], "gripper.servo_deg": [0.0, 100.0],
         "finger.mimic": "gripper", "elbow.ids": [3, 4], "elbow.directions": [1, -1],
         "pitch.coupled": [5, 6], "pitch.row": [0.5, 0.5], "roll.coupled": [5, 6], "roll.row": [0.5, -0.5]}


def joint_map():
    v = defaults()
    v.update({f"joints.{k}": x for k, x in BLOCK.items()})
    return validate(v).settings.ros.joints


SERVOS = {1: 30.0, 2: 50.0, 3: 10.0, 4: -10.0, 5: 20.0, 6: 40.0}


def reading(mapping, table) -> dict[str, float]:
    r = read_joints(mapping, table)
    return dict(zip(r.names, r.position_rad.tolist()))


@pytest.mark.parametrize("name, measured", [("shoulder", 0.3), ("gripper", 0.025), ("elbow", -0.2), ("pitch", 0.05),
                                             ("roll", -0.4)])
def test_a_measured_joint_reads_the_measurement_and_every_other_joint_is_unchanged(name, measured):
    mapping, table = joint_map(), table_at(SERVOS)
    before = reading(mapping, table)
    zeros, why = Calibration((name,), (measured,)).zeros(mapping, table)
    assert not why
    live = LiveJoints(mapping)
    after_map = live.calibrate(zeros)
    assert live.map is after_map and after_map is not mapping  # replaced whole, the old one untouched
    after = reading(after_map, table)
    assert after[name] == pytest.approx(measured, abs=1e-9)
    assert all(after[n] == pytest.approx(v, abs=1e-12) for n, v in before.items() if n not in (name, "finger"))
    assert reading(mapping, table) == before
    # the joint's commands follow: the servo angle of the measured position is where the servo is now
    joint = after_map.joint(name)
    if joint.coupling is None:
        assert joint.to_servo_deg(measured) == pytest.approx(SERVOS[joint.dxl_id] if not joint.partners else 10.0,
                                                             abs=0.1)
    else:
        others = {n: after[n] for n in joint.coupling.names}
        servos = joint.coupling.servos_rad([others[n] for n in joint.coupling.names]) / DEG
        assert servos.tolist() == pytest.approx([SERVOS[5], SERVOS[6]], abs=0.1)


def test_the_mimic_of_a_calibrated_joint_follows_it():
    mapping, table = joint_map(), table_at(SERVOS)
    zeros, _ = Calibration(("gripper",), (0.03,)).zeros(mapping, table)
    assert reading(mapping.with_zeros(zeros), table)["finger"] == pytest.approx(0.03)


@pytest.mark.parametrize("names, positions, why", [
    ((), (), "no joint named"),
    (("shoulder",), (0.1, 0.2), "1 joint names but 2 positions"),
    (("shoulder", "shoulder"), (0.1, 0.2), "joint shoulder named twice"),
    (("finger",), (0.1,), "finger is a mimic joint (state only)"),
    (("knee",), (0.1,), "unknown joint 'knee' (known: "),
    (("shoulder",), (math.nan,), "shoulder: position nan is not a finite number"),
    (("shoulder",), (math.inf,), "shoulder: position inf is not a finite number"),
    (("x" * 5000,), (0.1,), "unknown joint 'xxx"),
])
def test_a_request_that_cannot_be_taken_is_refused_before_anything_is_read(names, positions, why):
    refusal = Calibration(names, positions).refusal(joint_map())
    assert why in refusal and len(refusal) < 400


def test_a_joint_whose_servo_was_never_read_is_refused():
    mapping = joint_map()
    zeros, why = Calibration(("shoulder", "gripper"), (0.1, 0.01)).zeros(mapping, table_at({1: 30.0}))
    assert zeros == {} and "gripper: no present position of servo(s) [2] read" in why


def test_the_file_keeps_every_joint_s_zero_and_loads_back(tmp_path):
    mapping, table = joint_map(), table_at(SERVOS)
    zeros, _ = Calibration(("shoulder", "roll"), (0.3, -0.4)).zeros(mapping, table)
    calibrated = mapping.with_zeros(zeros)
    path = tmp_path / "offsets.yaml"
    path.write_text(offsets_yaml(calibrated))
    loaded, line = load(path, mapping)
    assert reading(loaded, table) == pytest.approx(reading(calibrated, table), abs=1e-12)
    assert line.startswith("joint offsets of ") and f"loaded from {path}" in line
    assert set(line[len("joint offsets of "):line.index(" loaded")].split(", ")) == set(mapping.names)


def test_a_missing_file_loads_nothing_and_names_of_another_robot_are_ignored(tmp_path):
    mapping = joint_map()
    same, line = load(tmp_path / "none.yaml", mapping)
    assert same is mapping and "no joint calibration saved at" in line
    path = tmp_path / "other.yaml"
    path.write_text('joint_offsets:\n  "shoulder": 0.5\n  "knee": 1.0\n')
    loaded, line = load(path, mapping)
    assert loaded.joint("shoulder").zero == 0.5 and "not joints of this robot, ignored: knee" in line


@pytest.mark.parametrize("text, why", [
    ("joint_offsets: [1, 2]\n", "no 'joint_offsets:' map"),
    ("other: {}\n", "no 'joint_offsets:' map"),
    ("joint_offsets: {shoulder: .nan}\n", "is not a joint name with a finite offset"),
    ("joint_offsets: {shoulder: yes}\n", "is not a joint name with a finite offset"),
    ("joint_offsets: {shoulder: [\n", "not a readable YAML file"),
    (b"\xff\xfe", "not a readable YAML file"),
])
def test_a_file_that_is_not_a_calibration_stops_the_start_up_with_one_line(tmp_path, text, why):
    path = tmp_path / "bad.yaml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(ConfigError, match=why.replace("(", r"\(").replace("[", r"\[")):
        load(path, joint_map())


def test_a_file_larger_than_a_calibration_is_refused_unread(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("joint_offsets:\n" + "  a: 0.0\n" * 200_000)
    with pytest.raises(ConfigError, match="more than a calibration"):
        load(path, joint_map())


# ---------------------------------------------------------------------------- effort in N·m
def test_effort_in_nm_is_the_current_through_the_model_s_torque_per_ampere_and_the_joint_s_reduction():
    v = defaults()
    v.update({f"joints.{k}": x for k, x in BLOCK.items()})
    v["joint_state.effort_unit"] = "Nm"
    mapping = validate(v).settings.ros.joints
    assert mapping.effort_unit == "Nm" and mapping.with_zeros({"shoulder": 0.2}).effort_unit == "Nm"
    table = table_at(SERVOS)
    model = table.model(1)
    for dxl_id in SERVOS:
        table.set_value("present_current", dxl_id, round(500.0 / model.current_ma_per_pulse))  # ~0.5 A each
    amps = table.units("present_current")[0] / 1000.0
    r = read_joints(mapping, table)
    effort = dict(zip(r.names, r.effort_a.tolist()))
    per_amp = 4.1 / 2.3  # XM430-W350: stall torque 4.1 N·m at 2.3 A (12 V)
    assert effort["shoulder"] == pytest.approx(-amps * per_amp * 2.0)      # reduction 2, direction -1
    assert effort["gripper"] == pytest.approx(amps * per_amp * DEG / (0.04 / 100.0))  # N: through the stroke
    assert effort["elbow"] == pytest.approx(amps * per_amp - amps * per_amp)  # two servos, the second flipped
    assert math.isnan(effort["pitch"]) and math.isnan(effort["finger"])


def test_a_model_without_figures_gives_nan_and_an_unknown_unit_stops_the_start_up():
    from dynamixel_handler.joints import effort_per_amp
    mapping = joint_map()
    nm = replace(mapping, effort_unit="Nm")
    xl430 = model_by_number(1060)  # XL430-W250: no current sensor, no figures
    assert math.isnan(effort_per_amp(nm, DEG, xl430)) and effort_per_amp(mapping, -DEG, xl430) == -1.0
    v = defaults()
    v.update({"joints.a.id": 1, "joint_state.effort_unit": "kgf"})
    with pytest.raises(ConfigError, match="'joint_state.effort_unit' = 'kgf': A or Nm"):
        validate(v)
