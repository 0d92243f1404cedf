"""A servo family as one value of the control table: what each family answers and that every model
carries its family."""
import pytest

from dynamixel_handler.control_table import (
    FAMILIES,
    MAX_ROTATION,
    PRO,
    SERIES,
    P,
    X,
    family_named,
    family_titled,
    known_models,
    model_by_number,
)


def test_every_model_carries_the_family_of_its_series():
    for model in known_models():
        assert model.family is family_named(model.series)
        assert model.series == model.family.name
    assert model_by_number(1020).family is X
    assert model_by_number(2020).family is P
    assert model_by_number(54025).family is P  # PRO "-R(A)": the P table and units
    assert model_by_number(54024).family is PRO
    assert SERIES == tuple(f.name for f in FAMILIES)


def test_modes_per_family():
    assert X.modes == {"current", "velocity", "position", "ex_position", "cur_position", "pwm"}
    assert P.modes == X.modes - {"cur_position"}
    assert PRO.modes == {"current", "velocity", "position", "ex_position"}


def test_names_as_topics_and_parameters_spell_them():
    assert [(f.name, f.title, f.suffix) for f in FAMILIES][:3] == [("X", "X", "x"), ("P", "P", "p"), ("PRO", "Pro", "pro")]
    assert family_titled(" pro ") is PRO and family_titled("X") is X and family_titled("mx") is None
    assert family_named(P) is P
    with pytest.raises(KeyError, match="unknown servo series 'Q'"):
        family_named("Q")


def test_dummy_models_are_of_their_family():
    for family in FAMILIES:
        assert model_by_number(family.dummy_model).family is family


def test_speed_of_a_move_in_position_modes():
    # X and P: the profile velocity field; the old PRO (no Profile Velocity): its goal velocity
    assert (X.move_speed_field, X.speed_item(True)) == ("profile_vel_deg_s", "profile_velocity")
    assert (P.move_speed_field, P.speed_item(True)) == ("profile_vel_deg_s", "profile_velocity")
    assert (PRO.move_speed_field, PRO.speed_item(False)) == ("velocity_deg_s", "goal_velocity")
    assert not X.speed_item_is_per_model and PRO.speed_item_is_per_model
    assert not model_by_number(54024).has("profile_velocity")


def test_goal_position_bounds():
    x = model_by_number(1020).item("goal_position")
    # X: the register's range in position mode without limits, ±1,048,575 pulses in multi-turn modes
    assert X.goal_position_bounds(x.min_raw, x.max_raw, 360 / 4096) == (x.min_raw, x.max_raw, -1_048_575, 1_048_575)
    # P / PRO: ±256 turns of the model in every mode
    p = model_by_number(2020)
    turns = round(MAX_ROTATION * 360.0 / p.position_deg_per_pulse)
    assert P.goal_position_bounds(-(1 << 31), (1 << 31) - 1, p.position_deg_per_pulse) == (-turns, turns, -turns, turns)


def test_profile_bounds():
    assert X.profile_bounds((1 << 31) - 1) == (0, 32767)  # e-Manual: whatever the limits
    assert P.profile_bounds((1 << 31) - 1) == (0, (1 << 31) - 1)


def test_families_are_frozen_values():
    with pytest.raises(AttributeError):
        X.profile_max = 1  # type: ignore[misc]
    assert X.profile_max == 32767
