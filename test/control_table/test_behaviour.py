"""Each family's behaviour (``control_table.behaviour``): how its error state is decoded and
cleared, where the speed of a move goes and what 0 means there, which command topics it takes.
Expected values are the e-Manual's, as the family tests give them (test_table_y, test_table_xl320,
test_table_protocol1, test_family)."""
from __future__ import annotations

import pytest

from dynamixel_handler.control_table import PRO, P, X, family_named, model_by_number, protocol1_model_by_number
from dynamixel_handler.control_table.behaviour import (
    ByClearInstruction,
    ByReboot,
    ByWritingAgain,
    ErrorCodeBehaviour,
    FamilyBehaviour,
    MovingSpeedBehaviour,
    Protocol1Behaviour,
)
from dynamixel_handler.servo import error_state
from dynamixel_handler.servo.table import ServoTable

XM430 = model_by_number(1020)
OLD_PRO = model_by_number(54024)  # H54-200-S500-R: no Profile Velocity
YM080 = model_by_number(4170)
XL320 = model_by_number(350)
AX12 = protocol1_model_by_number(12)
#: the Clear instruction's parameters that clear a Y error code: 0x02, then "ERCL"
ERROR_CLEAR = bytes([0x02, 0x45, 0x52, 0x43, 0x4C])


def _mode_not_asked() -> str:
    raise AssertionError("the mode was asked where it does not matter")


def test_one_behaviour_object_per_family_of_the_kind_it_needs():
    kinds = {name: type(family_named(name).behaviour) for name in ("X", "P", "PRO", "Y", "XL320", "AX", "MX1")}
    assert kinds == {"X": FamilyBehaviour, "P": FamilyBehaviour, "PRO": FamilyBehaviour, "Y": ErrorCodeBehaviour,
                     "XL320": MovingSpeedBehaviour, "AX": Protocol1Behaviour, "MX1": Protocol1Behaviour}
    assert all(m.family.behaviour is m.family.behaviour for m in (XM430, YM080, XL320, AX12))


def test_x_hardware_error_bits_cleared_by_a_reboot():
    b = XM430.family.behaviour
    assert b.error_item == "hardware_error_status" and b.status_error_item is None
    # Hardware Error Status: 0x24 = overheating (bit 2) and overload (bit 5), in the X layout already
    assert b.common_bits(0x24) == 0x24 and b.own_bits(0x24) == 0x24 and b.hardware_bits(0x24) == 0x24
    assert b.is_error(0x24) and not b.is_error(0) and not b.is_error(None)
    assert b.describe(0x24) == "0x24"
    # Shutdown 0x34 (its factory value: overheating, electrical shock, overload) switches torque off
    # on an overload, not on an input voltage error; unknown Shutdown: any bit
    assert b.torque_cut(0x20, 0x34) and not b.torque_cut(0x01, 0x34) and b.torque_cut(0x01, None)
    assert b.clearing == ByReboot()


def test_y_error_code_cleared_by_the_clear_instruction_with_its_key():
    b = YM080.family.behaviour
    assert b.error_item == "error_code" and b.error_codes is YM080.family.error_codes
    assert b.describe(5) == "error code 5 (Overload Error)" and b.hardware_bits(5) == 0x20
    assert b.is_error(5) and not b.is_error(9) and not b.is_error(0)  # 9: battery warning, the servo runs on
    assert b.is_error(99)  # a code the manual lacks counts as an error
    # 5 overload switches torque off; 18 bus watchdog error holds the servo with torque on
    assert b.torque_cut(5) and not b.torque_cut(18) and b.torque_cut(99)
    assert b.clearing == ByClearInstruction(ERROR_CLEAR)


def test_xl320_bits_in_its_own_order_cleared_by_a_reboot():
    b = XL320.family.behaviour
    overload, overheating, input_voltage = 0b001, 0b010, 0b100
    assert (b.common_bits(overload), b.common_bits(overheating), b.common_bits(input_voltage)) == (0x20, 0x04, 0x01)
    assert all(b.own_bits(b.common_bits(bits)) == bits for bits in range(8))
    assert b.hardware_bits(overload) == 0x20 and b.describe(overload) == "0x01"
    assert b.clearing == ByReboot()


def test_protocol1_error_in_the_status_byte_cleared_by_writing_torque_limit_again():
    b = AX12.family.behaviour
    # status error bits: 0 input voltage, 1 angle limit, 2 overheating, 3 range, 4 checksum, 5 overload,
    # 6 instruction; the state is input voltage, overheating and overload, where the X layout has them
    assert b.status_error_item == "hardware_error_status" == b.error_item
    assert b.status_state(0x7F) == 0x25 and b.status_state(0x1A) == 0
    assert b.common_bits(0x7F) == 0x25 and b.own_bits(0x25) == 0x25
    assert b.describe(0x20) == "overload error (0x20)" and b.describe(0) == "no error"
    assert b.torque_cut(0x20) and not b.torque_cut(0)
    assert b.clearing == ByWritingAgain("torque_limit", "pwm_limit")  # Torque Limit from Max Torque
    table = ServoTable()
    table.add(4, AX12)
    assert error_state.keep_status_error(table, 4, 0x7F) == 0x25 and table.value("hardware_error_status", 4) == 0x25


def test_speed_of_a_move_to_profile_velocity_or_the_family_item():
    x, pro = XM430.family.behaviour, OLD_PRO.family.behaviour
    assert x.speed_item(XM430) == "profile_velocity" and not x.speed_in_position_only(XM430)
    assert x.control_speed_item(XM430, "profile_vel_deg_s", "position") == "profile_velocity"
    assert x.control_speed_item(XM430, "profile_vel_deg_s", "velocity") is None
    assert x.control_speed_item(XM430, "position_deg", "position") is None
    # the old PRO: velocity_deg_s of its position control is Goal Velocity, an item per model
    assert pro.speed_field == "velocity_deg_s" and pro.speed_item(OLD_PRO) == "goal_velocity"
    assert pro.control_speed_item(OLD_PRO, "velocity_deg_s", "ex_position") == "goal_velocity"
    assert pro.speed_per_model("velocity_deg_s", "position") and not pro.speed_per_model("velocity_deg_s", "velocity")
    assert not x.speed_per_model("profile_vel_deg_s", "position")
    assert x.speed_pulses(0, _mode_not_asked) == 0 and pro.speed_pulses(0, _mode_not_asked) == 0


@pytest.mark.parametrize("model", [XL320, AX12], ids=["XL-320", "AX-12A"])
def test_moving_speed_is_the_speed_of_a_move_in_joint_mode_where_0_is_fastest(model):
    b = model.family.behaviour
    assert b.speed_in_position_only(model) and b.speed_item(model) == "goal_velocity"
    assert b.speed_pulses(0, lambda: "position") == 1 and b.speed_pulses(0, lambda: "ex_position") == 1
    assert b.speed_pulses(0, lambda: "velocity") == 0  # Wheel Mode: 0 is stop
    assert b.speed_pulses(30, _mode_not_asked) == 30


def test_the_command_topics_each_family_takes():
    assert (X.command_family, P.command_family, PRO.command_family) == (X, P, PRO)
    assert XL320.family.command_family is X  # the X topics and messages
    assert YM080.family.command_family is None and AX12.family.command_family is None  # series-independent only


def test_the_behaviour_says_how_a_mode_is_selected():
    """The Operating Mode register (X, P, PRO, Y, XL-320), or the Angle Limits and, where the model
    has it, Torque Control Mode Enable (Protocol 1.0): ``Model.mode_select`` is its family's answer."""
    from dynamixel_handler.control_table import known_models, protocol1_models

    assert all(m.mode_select is None for m in known_models())
    for model in protocol1_models():
        select = model.mode_select
        assert select is not None and select is model.mode_select  # asked once per model
        assert select.top == model.position_max_pulse
        assert select.torque_control == model.has("torque_control_mode_enable")
