"""``commands.joint_goals.JointGoals``: joint commands by name in SI units. What a joint is given
picks its servo's mode; the angle follows the joint's direction and offset; a command that cannot
be taken is refused whole with one line; joints held where they are; positions and bounds read back
in the joint's frame."""
import math

import pytest

from dynamixel_handler import units
from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.joint_goals import JointGoals
from dynamixel_handler.joints import DEG, Joint, JointMap

from support.servo_access import FakeAccess, attached, warnings_of

XM430 = 1020
RAD = 180.0 / math.pi
#: shoulder: ID 1 as is; elbow: ID 2 turned round and 90 deg off; wrist: ID 5, not handled
MAPPING = JointMap.simple(("shoulder", "elbow", "wrist"), (1, 2, 5), (1, -1, 1), (0.0, 90.0, 0.0))
VALUES = {"min_position_limit": {1: 1024, 2: 1024}, "max_position_limit": {1: 3072, 2: 3072},
          "velocity_limit": {1: 200, 2: 200}, "current_limit": {1: 1193, 2: 1193}}


def _goals(modes=None):
    access = FakeAccess({1: XM430, 2: XM430}, modes=modes, values=VALUES)
    lines = warnings_of(access)
    return attached(JointGoals(attached(Commander(access)), MAPPING)), access, lines


def _pulses(access, item, value):
    return int(units.unit_to_pulse([access.model(1)], item, [value])[0])


@pytest.mark.parametrize("args, line", [
    (([], [0.0]), "j: no joint names: refused"),
    ((["shoulder"], [0.0, 1.0]), "j: 2 position values for 1 joint names: refused"),
    ((["shoulder"], []), "j: no position, velocity or effort given: nothing to do"),
    ((["knee"], [0.0]), "j: unknown joint names 'knee' (known: shoulder, elbow, wrist): refused"),
    ((["elbow", "elbow"], [0.0, 0.0]), "j: a joint is named twice in ['elbow', 'elbow']: refused"),
])
def test_a_command_that_cannot_be_taken_is_refused_whole_with_one_line(args, line):
    goals, access, lines = _goals()
    assert not goals.command("j", *args)
    assert lines == [line] and access.goals == [] and access.calls == []


def test_a_position_is_a_position_goal_in_the_servos_frame_its_mode_switched_where_needed():
    goals, access, lines = _goals(modes={2: "velocity"})
    assert goals.command("j", ["shoulder", "elbow"], position=[0.5, 0.5])
    assert ("change_mode", 2, "position") in access.calls
    deg = 0.5 * RAD
    assert access.goals == [{"goal_position": {1: _pulses(access, "goal_position", deg),
                                               2: _pulses(access, "goal_position", -deg + 90.0)}}]
    assert lines == []


def test_a_position_with_an_effort_is_current_based_position_control_and_a_velocity_alone_velocity_control():
    goals, access, _ = _goals()
    goals.command("j", ["shoulder"], position=[0.0], effort=[-0.5])
    assert ("change_mode", 1, "cur_position") in access.calls
    assert access.goals[-1] == {"goal_position": {1: 2048}, "goal_current": {1: _pulses(access, "goal_current", 500.0)}}
    goals.command("j", ["elbow"], velocity=[1.0])  # turned round: the servo turns the other way
    assert ("change_mode", 2, "velocity") in access.calls
    assert access.goals[-1] == {"goal_velocity": {2: _pulses(access, "goal_velocity", -RAD)}}


def test_a_servo_in_extended_position_mode_keeps_its_mode_for_a_position():
    goals, access, _ = _goals(modes={1: "ex_position"})
    goals.command("j", ["shoulder"], position=[4 * math.pi])  # two turns
    assert not any(call[0] == "change_mode" for call in access.calls)
    assert access.goals == [{"goal_position": {1: _pulses(access, "goal_position", 720.0)}}]


def test_a_joint_whose_servo_is_not_handled_is_named_and_the_others_are_written():
    goals, access, lines = _goals()
    goals.command("j", ["shoulder", "wrist"], position=[0.0, 0.0])
    assert access.goals == [{"goal_position": {1: 2048}}]
    assert lines == ["j: joints ['wrist'] map to servos that are not handled: ignored"]


def test_joints_are_held_where_they_are_and_read_back_in_their_own_frame():
    goals, access, _ = _goals()
    access.table.set_value("present_position", 1, 2048 + 512)   # 45 deg
    access.table.set_value("present_position", 2, 2048 + 1024)  # 90 deg: the elbow's zero
    access.table.set_value("present_velocity", 2, 10)
    goals.hold("stop", ["shoulder", "elbow"])
    assert access.goals == [{"goal_position": {1: 2048 + 512, 2: 2048 + 1024}}]
    position, velocity = goals.present(["shoulder", "elbow", "wrist"])
    assert position[:2] == pytest.approx([math.pi / 4, 0.0]) and math.isnan(position[2])
    assert velocity[1] == pytest.approx(-10 * access.model(2).velocity_deg_s_per_pulse / RAD)


def test_position_bounds_are_the_servos_limits_in_the_joints_frame():
    goals, access, _ = _goals()
    lo, hi = goals.position_bounds(["shoulder", "elbow", "wrist"])
    half = 0.5 * access.model(1).position_deg_per_pulse
    assert lo[0] == pytest.approx((-90.0 - half) / RAD) and hi[0] == pytest.approx((90.0 + half) / RAD)
    assert lo[1] == pytest.approx((0.0 - half) / RAD) and hi[1] == pytest.approx((180.0 + half) / RAD)
    assert lo[2] == -math.inf and hi[2] == math.inf


#: elbow: servos 1 and 2 on one axis, 2 mounted the other way round; a 2:1 reduction
PAIRED = JointMap((Joint("elbow", 1, DEG / 2.0, 0.0, partners=((2, -DEG / 2.0),), disagreement=2.0 * DEG),))


def test_a_joint_of_two_servos_writes_both_in_one_goal_each_with_its_direction():
    access = FakeAccess({1: XM430, 2: XM430}, values=VALUES)
    goals = attached(JointGoals(attached(Commander(access)), PAIRED))
    assert goals.command("j", ["elbow"], position=[0.25])
    deg = 0.25 * 2.0 * RAD  # the reduction: the servos turn twice as far
    assert access.goals == [{"goal_position": {1: _pulses(access, "goal_position", deg),
                                               2: _pulses(access, "goal_position", -deg)}}]  # one goal, one write


def test_servos_of_one_joint_that_disagree_hold_it_said_once_a_second_and_a_later_command_is_taken():
    access = FakeAccess({1: XM430, 2: XM430}, values=VALUES)
    lines = warnings_of(access)
    goals = attached(JointGoals(attached(Commander(access)), PAIRED))
    for dxl_id, deg in ((1, 10.0), (2, -10.0)):  # the joint at 5 deg from both: they agree
        access.table.set_value("present_position", dxl_id, _pulses(access, "present_position", deg))
    goals.watch_pairs()
    assert goals.held == set() and access.goals == []
    access.table.set_value("present_position", 2, _pulses(access, "present_position", -20.0))  # 5 deg of joint apart
    goals.watch_pairs()
    goals.watch_pairs()
    assert goals.held == {"elbow"}
    assert access.goals == [{"goal_position": {1: _pulses(access, "goal_position", 10.0),
                                               2: _pulses(access, "goal_position", -20.0)}}]  # each where it is, once
    said = [line for line in lines if line.startswith("joint elbow: servos [1, 2] disagree by 5.0")]
    assert len(said) == 1 and said[0].endswith("(more than joints.elbow.disagreement_deg 2): held where each was"), lines
    goals.command("j", ["elbow"], position=[0.5])  # taken: the same joint goal for both
    deg = 0.5 * 2.0 * RAD
    assert access.goals[-1] == {"goal_position": {1: _pulses(access, "goal_position", deg),
                                                  2: _pulses(access, "goal_position", -deg)}}
    access.table.set_value("present_position", 2, _pulses(access, "present_position", -10.0))
    goals.watch_pairs()
    assert goals.held == set()


def test_a_coupled_set_writes_every_servo_solved_from_the_joints_given_and_the_others_present():
    from dynamixel_handler.joints import Coupling
    coupling = Coupling((1, 2), ("pitch", "roll"), ((0.5, 0.5), (0.5, -0.5)), (0.0, 0.0))
    mapping = JointMap((Joint("pitch", 1, 0.5 * DEG, 0.0, partners=((2, 0.5 * DEG),), coupling=coupling),
                        Joint("roll", 1, 0.5 * DEG, 0.0, partners=((2, -0.5 * DEG),), coupling=coupling)))
    access = FakeAccess({1: XM430, 2: XM430}, values=VALUES)
    lines = warnings_of(access)
    goals = attached(JointGoals(attached(Commander(access)), mapping))
    goals.command("j", ["pitch"], position=[0.1])
    assert lines == ["j: the coupled joints ['pitch', 'roll'] have no position read yet: ignored"]
    for dxl_id in (1, 2):  # both servos at 20 deg: pitch 20 deg, roll 0
        access.table.set_value("present_position", dxl_id, _pulses(access, "present_position", 20.0))
    assert goals.command("j", ["pitch"], position=[0.1])
    assert access.goals == [{"goal_position": {1: _pulses(access, "goal_position", 0.1 * RAD),
                                               2: _pulses(access, "goal_position", 0.1 * RAD)}}]  # roll kept at 0
    goals.command("j", ["roll", "pitch"], position=[0.1, 0.2])
    assert access.goals[-1] == {"goal_position": {1: _pulses(access, "goal_position", 0.3 * RAD),
                                                  2: _pulses(access, "goal_position", 0.1 * RAD)}}
    assert goals.present(["pitch", "roll"])[0] == pytest.approx([20.0 / RAD, 0.0], abs=1e-3)


def test_a_velocity_limit_caps_the_profile_and_joints_without_one_are_written_all_the_same():
    mapping = JointMap((Joint("fast", 1, DEG, 0.0), Joint("slow", 2, DEG / 2.0, 0.0, velocity_limit=3.0)))
    access = FakeAccess({1: XM430, 2: XM430}, values=VALUES)
    goals = attached(JointGoals(attached(Commander(access)), mapping))
    goals.command("j", ["fast", "slow"], position=[0.1, 0.2])
    # two Commander calls (their fields differ), one pending goal of each item: one sync write each
    assert access.pending.peek("goal_position") == {1: _pulses(access, "goal_position", 0.1 * RAD),
                                                    2: _pulses(access, "goal_position", 0.4 * RAD)}
    assert access.pending.peek("profile_velocity") == {2: _pulses(access, "profile_velocity", 6.0 * RAD)}  # 3 rad/s


def test_a_tiny_velocity_limit_is_never_written_as_the_profile_that_means_no_limit():
    mapping = JointMap((Joint("slow", 1, DEG, 0.0, velocity_limit=1e-6),))
    access = FakeAccess({1: XM430}, values={item: {1: v[1]} for item, v in VALUES.items()})
    goals = attached(JointGoals(attached(Commander(access)), mapping))
    goals.command("j", ["slow"], position=[0.1])
    assert access.pending.peek("profile_velocity") == {1: 1}  # the smallest step, not 0 (no limit)
