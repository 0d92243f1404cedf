"""One ``/diagnostics`` status per joint (``dynamixel_handler/joints/health.py``): its state in the
joint's units, its servos' worst level naming the servo, a joint beyond its soft limits and a
paired joint whose servos disagree raised to a warning, an unread joint an error. ROS-free."""
from __future__ import annotations

from dynamixel_handler.config import defaults, validate
from dynamixel_handler.joints.health import joint_health
from dynamixel_handler.servo.health import ERROR, OK, WARN
from dynamixel_handler.servo.table import ServoTable

from support.joint_tables import table_at as at


def joints():
    v = defaults()
    v.update({"joints.shoulder.id": 1, "joints.shoulder.reduction": 2.0, "joints.shoulder.limits.position": [-0.5, 0.5],
              "joints.gripper.id": 2, "joints.gripper.type": "prismatic", "joints.gripper.stroke": [0.0, 0.04],
              "joints.gripper.servo_deg": [0.0, 100.0], "joints.elbow.ids": [3, 4], "joints.finger.mimic": "gripper"})
    return validate(v).settings.ros.joints


def table_at(servo_deg: dict[int, float]) -> ServoTable:
    """Servos at ``servo_deg``, healthy: temperature, voltage and their limits, no error."""
    table = at(servo_deg)
    for dxl_id in servo_deg:
        for item, value in (("present_temperature", 30), ("temperature_limit", 80), ("present_input_voltage", 120),
                            ("max_voltage_limit", 160), ("min_voltage_limit", 95), ("hardware_error_status", 0)):
            table.set_value(item, dxl_id, value)
    return table


def by_name(statuses):
    return {h.name.split(": joint ")[1]: h for h in statuses}


def test_each_joint_driven_by_servos_has_a_status_in_its_units():
    status = by_name(joint_health(joints(), table_at({1: 20.0, 2: 50.0, 3: 10.0, 4: 10.0}), "robot/dynamixel_handler"))
    assert sorted(status) == ["elbow", "gripper", "shoulder"]  # a mimic joint has no status of its own
    shoulder = dict(status["shoulder"].values)
    assert abs(float(shoulder["position [rad]"]) - 0.17453) < 0.001  # a servo at 20 deg, a reduction of 2
    assert shoulder["limits [rad]"] == "[-0.5, 0.5]"
    assert shoulder["servos"] == "ID 1" and shoulder["effort [A]"] == "unknown"  # no current read yet
    assert abs(float(dict(status["gripper"].values)["position [m]"]) - 0.02) < 0.0001
    assert status["elbow"].values[-1] == ("servos apart [deg]", "0.00")
    assert all(h.level == OK for h in status.values()), [h.message for h in status.values()]


def test_a_joint_beyond_its_limits_a_pair_apart_and_a_silent_servo_are_said():
    table = table_at({1: 80.0, 2: 50.0, 3: 10.0, 4: 30.0})
    table.ping[table.index[2]] = False
    table.no_response[table.index[2]] = 3
    status = by_name(joint_health(joints(), table))
    assert status["shoulder"].level == WARN and "beyond its soft limits [-0.5, 0.5]" in status["shoulder"].message
    assert status["elbow"].level == WARN and "its servos disagree by 19.9" in status["elbow"].message
    assert status["gripper"].level == ERROR and status["gripper"].message.startswith("ID 2: no response for 3 read(s)")


def test_a_joint_never_read_is_an_error():
    status = by_name(joint_health(joints(), table_at({1: 0.0})))
    assert status["gripper"].level == ERROR and "position unknown" in status["gripper"].message
