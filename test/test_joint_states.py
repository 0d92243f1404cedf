"""joint_states: the mapped servos as joints in SI units, through the real node on the virtual bus."""
from __future__ import annotations

import math

from sensor_msgs.msg import JointState

from dynamixel_handler.config import ConfigError, defaults, validate
from dynamixel_handler.control_table import model_by_number

from support.rig import X540, P, Rig, X
from support.ros import NodeProcess, node_command


def _listen(rig: Rig) -> list[JointState]:
    got: list[JointState] = []
    with rig._lock:
        rig.node.create_subscription(JointState, "/joint_states", got.append, 50)
    return got


def test_joint_states_carry_the_mapped_servos_in_si_units_with_direction_and_offset():
    rig = Rig({1: X, 2: X540, 3: P}, "joint_state.use:=true", "joint_state.names:=[pan, tilt]",
              "joint_state.ids:=[3, 1]", "joint_state.directions:=[1, -1]", "joint_state.offsets_deg:=[0.0, 10.0]",
              "init/torque_auto_enable:=false")
    try:
        pulses = {1: (2048 + 512, 5, -40), 3: (-100000, -7, 250)}  # position, velocity, current
        for dxl_id, (pos, vel, cur) in pulses.items():
            servo = rig.sim.servo(dxl_id)
            servo.pin("present_position", pos)
            servo.pin("present_velocity", vel)
            servo.pin("present_current", cur)
        got = _listen(rig)
        rig.wait(lambda: len(got) >= 3, timeout=10, what="joint states read after the sensors were pinned")
        msg = got[-1]
        assert list(msg.name) == ["pan", "tilt"]  # parameter order; ID 2 is not mapped
        assert msg.header.stamp.sec > 0

        xm, ph = model_by_number(X), model_by_number(P)
        expect = {  # name: (model, pulses, direction, offset_deg)
            "pan": (ph, pulses[3], 1, 0.0),
            "tilt": (xm, pulses[1], -1, 10.0),
        }
        for k, name in enumerate(msg.name):
            model, (pos, vel, cur), direction, offset = expect[name]
            deg = (pos - model.position_zero_pulse) * model.position_deg_per_pulse
            assert math.isclose(msg.position[k], direction * math.radians(deg - offset), abs_tol=1e-9)
            assert math.isclose(msg.velocity[k], direction * math.radians(vel * model.velocity_deg_s_per_pulse),
                                abs_tol=1e-9)
            assert math.isclose(msg.effort[k], direction * cur * model.current_ma_per_pulse / 1000.0, abs_tol=1e-9)
        # tilt: XM430 at +45 deg, offset 10, flipped -> -35 deg
        assert math.isclose(msg.position[1], math.radians(-35.0), abs_tol=1e-9)
    finally:
        assert rig.close() == 0


def test_joint_states_are_off_by_default():
    rig = Rig({1: X})
    try:
        got = _listen(rig)
        rig.fresh_states(count=20)
        assert got == []
        with rig._lock:
            assert rig.node.count_publishers("/joint_states") == 0
    finally:
        rig.close()


def test_bad_joint_mappings_are_refused_with_one_clear_line():
    def problem(**values) -> str:
        v = defaults()
        v.update({f"joint_state.{k}": x for k, x in values.items()})
        try:
            validate(v)
        except ConfigError as err:
            return str(err)
        return ""

    assert problem(names=["a", "b"], ids=[1, 2]) == ""
    assert "same length" in problem(names=["a", "b"], ids=[1])
    assert "repeats a" in problem(names=["a", "a"], ids=[1, 2])
    assert "empty name at index 1" in problem(names=["a", " "], ids=[1, 2])
    assert "servo IDs are 0..252" in problem(names=["a"], ids=[253])
    assert "one joint per servo" in problem(names=["a", "b"], ids=[4, 4])
    assert "each must be 1 or -1" in problem(names=["a", "b"], ids=[1, 2], directions=[1, 2])
    assert "3 values for 2 joints" in problem(names=["a", "b"], ids=[1, 2], offsets_deg=[0.0, 1.0, 2.0])
    assert "map no joint" in problem(use=True)


def test_the_node_stops_on_a_bad_mapping_with_one_clear_line():
    node = NodeProcess(node_command("debug:=true", "joint_state.use:=true", "joint_state.names:=[a, a]",
                                    "joint_state.ids:=[1, 2]"))
    assert node.wait_exit() == 2
    assert "parameter 'joint_state.names' repeats a" in node.output
    assert "Traceback" not in node.output
