"""A slow profile is never "no limit": on every model of every family, a value above 0 of an item
whose register value 0 the servo takes for no limit (Profile Velocity and Acceleration, the MX's
and old Pro's Goal Acceleration; Moving Speed in Joint Mode on the XL-320 and Protocol 1.0 models)
is written as the smallest step, 1, by every door that converts units: the commands' conversion,
the ``servos`` block and the set-up tool."""
from __future__ import annotations

import pytest

from dynamixel_handler import units
from dynamixel_handler.control_table import known_models, protocol1_models
from dynamixel_handler.servo_targets import to_pulses
from dynamixel_handler.setup_tool.items import parse_value, unit_of

MODELS = {model.name: model for model in [*known_models(), *protocol1_models()]}
FIELD_OF = {"profile_velocity": "profile_vel_deg_s", "profile_acceleration": "profile_acc_deg_ss"}


def _cases() -> list[tuple[str, str]]:
    """(model, item) of every item 0 means no limit on, where the model has it with a unit."""
    out = []
    for name, model in MODELS.items():
        for item in sorted(units.ZERO_IS_UNLIMITED):
            if model.has(item) and units.quantity_of(item) is not None:
                offset, scale = units.conversion([model], item)
                if scale[0] == scale[0]:  # a unit (not NaN)
                    out.append((name, item))
    return out


CASES = _cases()


def test_the_cases_span_every_family_that_has_a_profile():
    families = {MODELS[name].family.name for name, _ in CASES}
    with_profile = {m.family.name for m in MODELS.values() if any(m.has(i) for i in units.ZERO_IS_UNLIMITED)}
    assert families == with_profile and len(families) >= 5, (families, with_profile)


@pytest.mark.parametrize("name, item", CASES, ids=[f"{n}-{i}" for n, i in CASES])
def test_a_value_under_one_step_is_written_as_one_step_not_as_no_limit(name, item):
    model = MODELS[name]
    _, scale = units.conversion([model], item)
    tiny = 0.4 * float(scale[0])  # rounds to 0, the register value for "no limit"
    assert units.under_one_step(model, item, tiny)
    assert units.unit_to_pulse([model], item, [tiny]).tolist() == [1]
    assert units.unit_to_pulse([model], item, [0.0]).tolist() == [0]       # 0 asked: 0 it is
    assert units.unit_to_pulse([model], item, [3 * float(scale[0])]).tolist() == [3]  # the rest as before
    assert not units.under_one_step(model, item, 0.0)
    # the servos block
    if FIELD_OF[item] and model.has(item):
        assert to_pulses(model, FIELD_OF[item], tiny) == 1
    # the set-up tool, with the item's own unit
    spec = model.item(item)
    own = unit_of(model, spec)
    assert own
    assert parse_value(model, spec, f"{tiny:.9g}{own}", "test") == 1


MOVING_SPEED = [name for name, m in MODELS.items() if m.family.behaviour.speed_in_position_only(m)]


@pytest.mark.parametrize("name", MOVING_SPEED)
def test_the_speed_of_a_move_in_joint_mode_is_never_moving_speed_0(name):
    """XL-320 and Protocol 1.0: Moving Speed 0 in Joint Mode is as fast as the motor goes."""
    model = MODELS[name]
    item = model.family.speed_item(False)
    _, scale = units.conversion([model], item)
    assert to_pulses(model, "profile_vel_deg_s", 0.4 * float(scale[0])) == 1
    assert to_pulses(model, "profile_vel_deg_s", 0.0) == 1
