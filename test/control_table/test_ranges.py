"""The e-Manual value ranges as data (``_ranges``, ``Model.ranges`` / ``value_range``): every model
has a range for each listed item it has, within its register's bytes, holding its factory value;
the byte range is kept only where it is said to be."""

import pytest

from dynamixel_handler.control_table import RANGED_ITEMS, known_models, model_by_number
from dynamixel_handler.control_table._ranges import RANGES


@pytest.mark.parametrize("model", known_models(), ids=lambda m: m.name)
def test_every_listed_item_has_a_range_holding_its_factory_value(model):
    for name, item in model.items.items():
        if name in RANGED_ITEMS:
            assert name in model.ranges, (model.name, name)
        if name not in model.ranges:
            continue
        lo, hi = model.ranges[name]
        assert item.min_raw <= lo <= hi <= item.max_raw, (model.name, name, lo, hi)
        assert model.value_range(name) == (lo, hi)
        if name in model.factory:
            assert lo <= model.factory[name] <= hi, (model.name, name, model.factory[name], lo, hi)
    for name in model.byte_range_items:  # the fallbacks: the register's own bytes, nothing narrower
        assert model.ranges[name] == (model.items[name].min_raw, model.items[name].max_raw), (model.name, name)


def test_every_model_with_ranges_is_known_and_every_known_model_has_some():
    known = {m.number for m in known_models()}
    assert set(RANGES) <= known
    assert known - set(RANGES) == set(), sorted(known - set(RANGES))


@pytest.mark.parametrize("number,item,expected", [
    (1020, "velocity_limit", (0, 1023)), (1020, "max_voltage_limit", (95, 160)), (1020, "position_p_gain", (0, 16383)),
    (1020, "homing_offset", (-1_044_479, 1_044_479)), (1020, "moving_threshold", (0, 1023)),
    (1020, "current_limit", (0, 1193)), (1040, "min_voltage_limit", (110, 300)), (1060, "max_voltage_limit", (60, 140)),
    (1200, "velocity_limit", (0, 2047)), (1200, "max_voltage_limit", (31, 70)), (1210, "min_voltage_limit", (55, 140)),
    (2020, "velocity_limit", (0, 2900)), (2020, "acceleration_limit", (0, 3_992_644)),
    (2020, "profile_velocity", (0, 2900)), (2020, "velocity_i_gain", (0, 32767)), (2000, "moving_threshold", (0, 2920)),
    (54024, "max_voltage_limit", (0, 400)), (4000, "velocity_limit", (0, 642_200)), (350, "temperature_limit", (0, 150)),
    (350, "id", (0, 252)),
    # the grippers (platform/rh_p12_rn): RH-P12-RN(A) ...
    (35074, "current_limit", (0, 1984)), (35074, "pwm_limit", (0, 2009)), (35074, "velocity_limit", (0, 2970)),
    (35074, "acceleration_limit", (0, 1_378_788)), (35074, "homing_offset", (0, 1150)),
    (35074, "max_voltage_limit", (150, 350)), (35074, "temperature_limit", (0, 100)), (35074, "secondary_id", (0, 255)),
    (35074, "return_delay_time", (0, 254)), (35074, "position_p_gain", (0, 32767)),
    (35074, "profile_acceleration", (0, 1_378_788)),
    # ... and RH-P12-RN (old PRO table)
    (35073, "current_limit", (0, 820)), (35073, "velocity_limit", (0, 2_147_483_647)),
    (35073, "max_voltage_limit", (0, 400)), (35073, "position_d_gain", (0, 32767)),
    (35073, "external_port_mode_1", (0, 3)), (35073, "temperature_limit", (0, 100)),
])
def test_the_e_manual_ranges_of_some_models(number, item, expected):
    assert model_by_number(number).value_range(item) == expected


def test_an_item_without_an_e_manual_range_keeps_its_bytes_and_is_named():
    model = model_by_number(54024)  # H54-200-S500-R: its page gives Homing Offset no range
    assert "homing_offset" in model.byte_range_items
    assert model.value_range("homing_offset") == (-(1 << 31), (1 << 31) - 1)
    assert "homing_offset" not in model_by_number(2020).byte_range_items


def test_the_grippers_keep_the_byte_range_only_where_their_pages_give_none():
    assert model_by_number(35074).byte_range_items == {"protocol_type"}  # RH-P12-RN(A): not on its page
    assert model_by_number(35073).byte_range_items == set()
