"""dynamixel_handler_setup refuses a value beyond the e-Manual range of the servo's model (the
model's ``value_range``, the same data the virtual bus answers Data Range Errors from): the limits
the manual gives per model (Velocity Limit, the voltage limits, the grippers' Current and PWM Limit)
and the gains, on three families and both grippers, as a process against the virtual bus, nothing
written (read back with dynamixel_sdk); the manual's bound itself is written."""
from __future__ import annotations

import pytest
import test_setup_tool
from test_setup_tool import one_error_line, sdk_read

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.setup_tool.items import show_value

sim_of = test_setup_tool.sim_of  # the fixture: the virtual bus as a process

# (item, address, size) per control table (ROBOTIS e-Manual)
X_ITEMS = {"velocity_limit": (44, 4), "max_voltage_limit": (32, 2), "min_voltage_limit": (34, 2),
           "position_p_gain": (84, 2), "velocity_i_gain": (76, 2)}
P_ITEMS = {"velocity_limit": (44, 4), "max_voltage_limit": (32, 2), "position_p_gain": (532, 2)}
# the grippers (e-Manual platform/rh_p12_rn): RH-P12-RN(A) (P table), RH-P12-RN (old PRO table)
RH_P12_RN_A_ITEMS = {"current_limit": (38, 2), "pwm_limit": (36, 2)}
RH_P12_RN_ITEMS = {"current_limit": (30, 2)}

# model, its number, its items, and a value beyond its e-Manual range per item (the manual's bound + 1)
CASES = [
    ("XM430-W350", 1020, X_ITEMS, {"velocity_limit": 1024, "max_voltage_limit": 161, "position_p_gain": 16384}),
    ("XL330-M288", 1200, X_ITEMS, {"velocity_limit": 2048, "min_voltage_limit": 30, "velocity_i_gain": 16384}),
    ("PH54-200-S500-R", 2020, P_ITEMS, {"velocity_limit": 2901, "max_voltage_limit": 351, "position_p_gain": 32768}),
    ("RH-P12-RN(A)", 35074, RH_P12_RN_A_ITEMS, {"current_limit": 1985, "pwm_limit": 2010}),  # 0 ~ 1,984 / 0 ~ 2,009
    ("RH-P12-RN", 35073, RH_P12_RN_ITEMS, {"current_limit": 821}),                          # 0 ~ 820
]


def tool(sim, *args: str):
    """The tool at the servo's rate (57600 bps, as it comes): the ranges, not the search, are this file's."""
    return test_setup_tool.tool(sim, *args, "--latency", "100", "--baud", "57600")


@pytest.mark.parametrize("name,number,items,beyond", CASES, ids=[c[0] for c in CASES])
def test_a_value_beyond_the_models_e_manual_range_is_refused_naming_the_range(sim_of, name, number, items, beyond):
    sim = sim_of(f"1:{name}")
    model = model_by_number(number)
    before = {item: sdk_read(sim.path, 57600, 1, *items[item]) for item in beyond}
    for item, raw in beyond.items():
        lo, hi = model.value_range(item)
        assert not lo <= raw <= hi, (item, raw, lo, hi)
        out = tool(sim, "set", "1", item, str(raw), "--raw", "--yes", "--force")
        assert out.returncode == 2, (item, out.text)
        shown = [show_value(model, model.items[item], v) for v in (lo, hi)]
        expected = f"{item} = {show_value(model, model.items[item], raw)} is outside what the e-Manual gives {name}: " \
                   f"{shown[0]} .. {shown[1]}"
        line = one_error_line(out)
        assert expected in line and "nothing written" in line, (expected, line)
    assert {item: sdk_read(sim.path, 57600, 1, *items[item]) for item in beyond} == before


def test_the_e_manual_bound_itself_is_written(sim_of):
    sim = sim_of("1:XL330-M288")
    out = tool(sim, "set", "1", "velocity_limit", "2047", "--raw", "--yes")  # X330: 0 ~ 2,047 (X430: 0 ~ 1,023)
    assert out.returncode == 0, out.text
    assert sdk_read(sim.path, 57600, 1, *X_ITEMS["velocity_limit"]) == 2047


@pytest.mark.parametrize("name,items,top", [
    ("RH-P12-RN(A)", RH_P12_RN_A_ITEMS, {"current_limit": 1984, "pwm_limit": 2009}),
    ("RH-P12-RN", RH_P12_RN_ITEMS, {"current_limit": 820}),
])
def test_the_top_of_a_grippers_e_manual_range_is_written(sim_of, name, items, top):
    sim = sim_of(f"1:{name}")
    for item, raw in top.items():  # lowered first, so the top is a write and not the factory value left
        for value in (raw // 2, raw):
            out = tool(sim, "set", "1", item, str(value), "--raw", "--yes")
            assert out.returncode == 0, (item, value, out.text)
            assert sdk_read(sim.path, 57600, 1, *items[item]) == value, (item, value)
