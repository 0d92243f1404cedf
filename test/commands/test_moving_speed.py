"""``commands.moving_speed``: where a goal's speed goes on a model whose one Moving Speed register
is the velocity goal in Wheel Mode and the speed of a move in Joint Mode (AX-12A, XL-320), and a
speed of 0 in Joint Mode ("as fast as the motor goes") never written as 0."""
from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.moving_speed import goal_item

from support.servo_access import FakeAccess, attached, warnings_of

AX12A, XL320, XM430 = 12, 350, 1020
AX_DEG_S = 0.111 * 6.0


def _commander(modes):
    access = FakeAccess({1: AX12A, 2: XL320, 3: XM430}, modes=modes)
    return attached(Commander(access)), access


def test_the_speed_of_a_move_goes_to_moving_speed_in_joint_mode_and_the_velocity_goal_is_not_written():
    c, access = _commander({1: "position", 2: "position", 3: "position"})
    c.goal([1, 2, 3], {"profile_vel_deg_s": [20.0, 20.0, 20.0], "velocity_deg_s": [5.0, 5.0, 5.0]})
    written = access.goals[-1]
    assert written["goal_velocity"] == {1: round(20.0 / AX_DEG_S), 2: round(20.0 / AX_DEG_S), 3: written["goal_velocity"][3]}
    assert set(written["profile_velocity"]) == {3}                    # the X servo has its own profile


def test_in_wheel_mode_the_velocity_goal_goes_to_moving_speed_and_the_profile_is_not_written():
    c, access = _commander({1: "velocity", 2: "velocity", 3: "velocity"})
    c.goal([1, 2], {"profile_vel_deg_s": [20.0, 20.0], "velocity_deg_s": [-5.0, 0.0]})
    assert access.goals[-1] == {"goal_velocity": {1: -round(5.0 / AX_DEG_S), 2: 0}}   # 0 stops it here


def test_a_speed_of_zero_in_joint_mode_is_written_as_the_slowest_with_one_line():
    access = FakeAccess({1: AX12A, 2: XL320, 3: XM430})
    lines = warnings_of(access)            # before the commander takes the access's log
    c = attached(Commander(access))
    c.goal([1, 2, 3], {"profile_vel_deg_s": [0.0, 0.0, 0.0]})
    assert access.goals[-1]["goal_velocity"] == {1: 1, 2: 1}
    assert access.goals[-1]["profile_velocity"] == {3: 0}             # X: 0 is "no profile", as the e-Manual says
    assert sum("Moving Speed 0 would move it as fast as the motor goes" in line for line in lines) == 2


def test_the_item_of_each_field_by_model_and_mode():
    _, joint = _commander({1: "position", 2: "position", 3: "position"})
    assert [goal_item(joint, "profile_vel_deg_s", i) for i in (1, 2, 3)] == ["goal_velocity", "goal_velocity", "profile_velocity"]
    assert [goal_item(joint, "velocity_deg_s", i) for i in (1, 3)] == [None, "goal_velocity"]
    assert goal_item(joint, "position_deg", 1) == "goal_position"
