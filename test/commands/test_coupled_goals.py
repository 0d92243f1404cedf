"""``commands.coupled_goals``: a differential's servo goals from its joints: positions solved with
the joints not commanded kept at their goals, velocities with the others at 0, within the joints'
velocity limits; an effort is one line, not a goal."""
import math

import pytest

from dynamixel_handler.commands.coupled_goals import coupled_goals, goal_joints
from dynamixel_handler.joints import DEG, Coupling, Joint, JointMap

from support.servo_access import FakeAccess, warnings_of

XM430 = 1020
COUPLING = Coupling((1, 2), ("pitch", "roll"), ((0.5, 0.5), (0.5, -0.5)), (0.0, 0.0))
MAPPING = JointMap((Joint("pitch", 1, 0.5 * DEG, 0.0, partners=((2, 0.5 * DEG),), coupling=COUPLING, velocity_limit=1.0),
                    Joint("roll", 1, 0.5 * DEG, 0.0, partners=((2, -0.5 * DEG),), coupling=COUPLING)))


def _access(goal_deg=None, present_deg=(20.0, 20.0)):
    access = FakeAccess({1: XM430, 2: XM430})
    model = access.model(1)
    for dxl_id, deg in zip((1, 2), present_deg):
        access.table.set_value("present_position", dxl_id, model.position_zero_pulse + round(deg / model.position_deg_per_pulse))
    for dxl_id, deg in zip((1, 2), goal_deg or ()):
        access.table.set_value("goal_position", dxl_id, model.position_zero_pulse + round(deg / model.position_deg_per_pulse))
    return access, warnings_of(access)


def test_the_joint_not_commanded_stays_at_its_goal_not_at_where_the_shaft_is_on_its_way():
    access, lines = _access(goal_deg=(30.0, 10.0), present_deg=(22.0, 18.0))  # moving towards pitch 20, roll 10
    assert goal_joints(access, COUPLING) == pytest.approx([20.0 * DEG, 10.0 * DEG], abs=1e-3)
    goals = coupled_goals(access, MAPPING, lines.append, "j", COUPLING, {"pitch": (0.0, None, None)})
    (control1, id1, f1), (control2, id2, f2) = goals
    assert (control1, id1, control2, id2) == ("position_control", 1, "position_control", 2)
    assert f1["position_deg"] == pytest.approx(10.0, abs=0.1) and f2["position_deg"] == pytest.approx(-10.0, abs=0.1)
    assert lines == []


def test_velocities_are_solved_with_the_others_at_zero_and_within_their_limits():
    access, lines = _access()
    goals = coupled_goals(access, MAPPING, lines.append, "j", COUPLING, {"pitch": (None, 5.0, None)})
    # pitch 5 rad/s cut to its limit of 1 rad/s; roll 0: both servos at 1 rad/s
    assert [(c, i) for c, i, _ in goals] == [("velocity_control", 1), ("velocity_control", 2)]
    assert [f["velocity_deg_s"] for _, _, f in goals] == pytest.approx([math.degrees(1.0)] * 2)


def test_an_effort_is_one_line_and_no_goal():
    access, lines = _access()
    assert coupled_goals(access, MAPPING, lines.append, "j", COUPLING, {"roll": (None, None, 0.3)}) == []
    assert lines == ["j: effort of the coupled joints ['pitch', 'roll'] is not handled: ignored"]
