"""The Protocol 1.0 models (AX, RX, DX, EX, MX with the 1.0 firmware) in the control table.

Expected values are written out from each model's e-Manual page (emanual.robotis.com, dxl/ax/ax-12a,
ax-12w, ax-18a; dxl/rx/rx-10, rx-24f, rx-28, rx-64; dxl/dx/dx-113, dx-116, dx-117; dxl/ex/ex-106+;
dxl/mx/mx-12w, mx-28, mx-64, mx-106): Model Number, the addresses of the table, the initial values,
0..1023 over 300 deg (AX/RX/DX), 0..4095 over a turn (MX) or over 250.92 deg (EX-106+), 0.111 rpm
a speed unit (0.114 on MX-28/64/106, 0.916 on MX-12W) with bit 10 the direction, the baud table.
"""
from __future__ import annotations

import pytest

from dynamixel_handler import units
from dynamixel_handler.control_table import (
    FAMILIES,
    PROTOCOL1_FAMILIES,
    family_named,
    known_models,
    model_by_number,
    protocol1_model_by_number,
    protocol1_models,
)
from dynamixel_handler.control_table._protocol1 import mode_of

M = protocol1_model_by_number

# number: (name, family, factory Baud Rate, CCW Angle Limit, Temperature Limit, Max Voltage, Max Torque)
PAGES = {
    12: ("AX-12A", "AX", 1, 1023, 70, 140, 1023), 300: ("AX-12W", "AX", 1, 1023, 70, 140, 1023),
    18: ("AX-18A", "AX", 1, 1023, 75, 140, 983), 10: ("RX-10", "RX", 34, 1023, 80, 190, 1023),
    24: ("RX-24F", "RX", 34, 1023, 80, 190, 1023), 28: ("RX-28", "RX", 34, 1023, 80, 190, 1023),
    64: ("RX-64", "RX", 34, 1023, 80, 190, 1023), 113: ("DX-113", "DX", 34, 1023, 85, 190, 1023),
    116: ("DX-116", "DX", 34, 1023, 85, 190, 1023), 117: ("DX-117", "DX", 34, 1023, 80, 190, 1023),
    107: ("EX-106+", "EX", 34, 4095, 80, 240, 1023), 360: ("MX-12W", "MX1", 1, 4095, 80, 160, 1023),
    29: ("MX-28", "MX1", 34, 4095, 80, 160, 1023), 310: ("MX-64", "MX1", 34, 4095, 80, 240, 1023),
    320: ("MX-106", "MX1", 34, 4095, 80, 160, 1023),
}


def test_every_model_of_the_five_families_and_none_is_the_handlers():
    assert {m.number for m in protocol1_models()} == set(PAGES)
    assert not {m.number for m in known_models()} & set(PAGES)
    for number in PAGES:
        with pytest.raises(KeyError):
            model_by_number(number)
    assert [f.title for f in PROTOCOL1_FAMILIES] == ["AX", "RX", "DX", "EX", "MX1"]
    assert not set(PROTOCOL1_FAMILIES) & set(FAMILIES)  # no init/used_servo_series key: not driven
    for family in PROTOCOL1_FAMILIES:
        assert family.protocol == 1 and not family.used_by_default and not family.series_topics
        assert family_named(family.name) is family and not family.has_protocol_type
    assert all(f.protocol == 2 and f.bulk_read for f in FAMILIES)
    assert [f.bulk_read for f in PROTOCOL1_FAMILIES] == [False, False, False, True, True]


@pytest.mark.parametrize("number", sorted(PAGES))
def test_each_page_model_number_and_initial_values(number):
    name, family, baud, ccw, temperature, max_v, torque = PAGES[number]
    m = M(number)
    assert (m.name, m.family.title, m.protocol) == (name, family, 1)
    f = m.factory
    assert (f["id"], f["baud_rate"], f["return_delay_time"], f["min_position_limit"]) == (1, baud, 250, 0)
    assert (f["max_position_limit"], f["temperature_limit"], f["min_voltage_limit"]) == (ccw, temperature, 60)
    assert (f["max_voltage_limit"], f["pwm_limit"], f["status_return_level"]) == (max_v, torque, 2)
    assert (f["alarm_led"], f["shutdown"], f["torque_enable"], f["lock"]) == (36, 36, 0, 0)
    assert m.ram_copies == {"pwm_limit": "torque_limit"}  # Torque Limit takes Max Torque at power on
    for item, value in f.items():
        assert m.item(item).min_raw <= value <= m.item(item).max_raw, item


@pytest.mark.parametrize("number", sorted(PAGES))
def test_the_shared_table(number):
    m = M(number)
    for item, address, size in (("model_number", 0, 2), ("firmware_version", 2, 1), ("id", 3, 1), ("baud_rate", 4, 1),
                                ("return_delay_time", 5, 1), ("min_position_limit", 6, 2),
                                ("max_position_limit", 8, 2), ("temperature_limit", 11, 1),
                                ("min_voltage_limit", 12, 1), ("max_voltage_limit", 13, 1), ("pwm_limit", 14, 2),
                                ("status_return_level", 16, 1), ("alarm_led", 17, 1), ("shutdown", 18, 1),
                                ("torque_enable", 24, 1), ("led", 25, 1), ("goal_position", 30, 2),
                                ("goal_velocity", 32, 2), ("torque_limit", 34, 2), ("present_position", 36, 2),
                                ("present_velocity", 38, 2), ("present_load", 40, 2),
                                ("present_input_voltage", 42, 1), ("present_temperature", 43, 1),
                                ("registered_instruction", 44, 1), ("moving", 46, 1), ("lock", 47, 1),
                                ("punch", 48, 2)):
        it = m.item(item)
        assert (it.address, it.size, it.eeprom) == (address, size, address < 24), item
    assert {"model_number", "firmware_version", "present_position", "present_velocity", "present_load",
            "present_input_voltage", "present_temperature", "registered_instruction", "moving"} <= m.read_only
    assert not {"id", "goal_position", "goal_velocity", "torque_limit", "lock", "punch"} & m.read_only
    for absent in ("operating_mode", "hardware_error_status", "profile_velocity", "homing_offset", "bus_watchdog",
                   "protocol_type", "velocity_limit", "current_limit"):
        assert not m.has(absent), absent


def test_compliance_on_ax_rx_dx_ex_and_gains_on_mx():
    for number in (12, 300, 18, 10, 24, 28, 64, 113, 116, 117, 107):
        m = M(number)
        assert [m.item(n).address for n in ("cw_compliance_margin", "ccw_compliance_margin", "cw_compliance_slope",
                                            "ccw_compliance_slope")] == [26, 27, 28, 29]
        assert not m.has("position_p_gain") and not m.has("multi_turn_offset")
    assert (M(300).factory["cw_compliance_margin"], M(300).factory["cw_compliance_slope"]) == (4, 64)  # AX-12W
    assert (M(113).factory["cw_compliance_margin"], M(117).factory["cw_compliance_margin"]) == (0, 1)
    for number in (360, 29, 310, 320):
        m = M(number)
        assert [m.item(n).address for n in ("position_d_gain", "position_i_gain", "position_p_gain")] == [26, 27, 28]
        assert (m.item("multi_turn_offset").address, m.item("multi_turn_offset").signed) == (20, True)
        assert (m.item("resolution_divider").address, m.item("realtime_tick").address) == (22, 50)
        assert m.item("profile_acceleration").address == 73  # Goal Acceleration
        assert m.item("goal_position").signed and m.item("present_position").signed  # multi-turn: two's complement
        assert not m.has("cw_compliance_margin")
    assert (M(360).factory["position_d_gain"], M(360).factory["position_p_gain"], M(360).factory["punch"]) == (8, 8, 32)
    assert (M(29).factory["position_d_gain"], M(29).factory["position_p_gain"], M(29).factory["punch"]) == (0, 32, 0)


def test_current_items_where_the_model_has_them():
    for number in (310, 320):  # MX-64, MX-106: Current 68, Torque Control Mode Enable 70, Goal Torque 71
        m = M(number)
        assert (m.item("present_current").address, m.item("torque_control_mode_enable").address) == (68, 70)
        assert (m.item("goal_current").address, m.item("goal_current").direction_bit) == (71, 10)
        assert (m.current_ma_per_pulse, m.item_zero["present_current"]) == (4.5, 2048)
        assert "current" in m.modes
    ex = M(107)  # Sensed Current 56: 10 mA, 512 = 0 mA
    assert (ex.item("present_current").address, ex.current_ma_per_pulse, ex.item_zero["present_current"]) == \
        (56, 10.0, 512)
    assert not ex.has("goal_current") and "current" not in ex.modes
    for number in (12, 18, 28, 117, 360, 29):
        assert not M(number).has("present_current") and not M(number).has("goal_current")
    assert M(107).item("drive_mode").address == 10 and M(320).item("drive_mode").address == 10
    assert not M(310).has("drive_mode") and not M(12).has("drive_mode")


def test_modes_by_angle_limits():
    assert mode_of(0, 1023) == "position" and mode_of(0, 0) == "velocity"
    assert mode_of(4095, 4095) == "ex_position" and mode_of(0, 4095, torque_control=1) == "current"
    assert M(12).modes == {"position", "velocity"} and M(113).modes == {"position"}  # DX: no Wheel Mode
    assert M(29).modes == {"position", "velocity", "ex_position"}
    assert M(310).modes == {"position", "velocity", "ex_position", "current"}
    assert family_named("MX1").multi_turn_goal == 28_672 and M(29).ranges["goal_position"] == (-28_672, 28_672)
    assert M(29).ranges["multi_turn_offset"] == (-24_576, 24_576) and M(29).ranges["resolution_divider"] == (1, 4)
    assert M(12).ranges["goal_position"] == (0, 1023) and M(107).ranges["goal_position"] == (0, 4095)


def test_positions_in_degrees_around_the_middle():
    ax, mx, ex = M(12), M(29), M(107)
    assert units.pulse_to_unit([ax] * 3, "goal_position", [0, 512, 1023]).tolist() == \
        pytest.approx([-150.1466, 0.0, 149.8534], abs=1e-3)  # 1023 steps over 300 deg
    assert units.unit_to_pulse([ax] * 3, "goal_position", [0.0, 90.0, -90.0]).tolist() == [512, 819, 205]
    assert units.pulse_to_unit([mx] * 3, "goal_position", [0, 2048, 3072]).tolist() == \
        pytest.approx([-180.0, 0.0, 90.0])  # 4096 steps a turn
    assert units.unit_to_pulse([mx] * 2, "goal_position", [90.0, -720.0]).tolist() == [3072, 2048 - 8192]
    low, high = units.pulse_to_unit([ex] * 2, "goal_position", [0, 4095]).tolist()
    assert (high - low, low) == pytest.approx((250.92, -2048 * 250.92 / 4095))  # 4095 steps over 250.92 deg
    assert units.unit_to_pulse([ex], "goal_position", [60.0]).tolist() == [2048 + 979]


def test_speeds_in_deg_s_with_the_direction_in_bit_10():
    ax, mx, mx12 = M(12), M(29), M(360)
    assert units.pulse_to_unit([ax, mx, mx12], "goal_velocity", [300, 300, 300]).tolist() == \
        pytest.approx([300 * 0.111 * 6, 300 * 0.114 * 6, 300 * 0.916 * 6])
    assert units.unit_to_pulse([ax] * 3, "goal_velocity", [66.6, -66.6, 1e6]).tolist() == [100, -100, 1023]
    item = ax.item("goal_velocity")
    assert units.encode(item, [100, -100]) == bytes([100, 0, 100, 4])  # -100: 1024 + 100
    assert units.decode(ax.item("present_velocity"), bytes([100, 4, 0, 4]), 2).tolist() == [-100, 0]
    assert units.decode(ax.item("present_load"), bytes([0x00, 0x06])).tolist() == [-512]  # CW load 51.2 %
    assert mx.acceleration_deg_ss_per_pulse == pytest.approx(8.583)


def test_baud_tables():
    ax, mx = M(12), M(29)
    assert {v: ax.baud_rates[v] for v in (1, 3, 4, 7, 9, 16, 34, 103, 207)} == {
        1: 1_000_000, 3: 500_000, 4: 400_000, 7: 250_000, 9: 200_000, 16: 115_200, 34: 57_600, 103: 19_200,
        207: 9_600}
    assert (ax.baud_rates[254], ax.baud_rates[250]) == (7843, 7968) and 0 not in ax.baud_rates  # no 2 Mbps
    assert ax.baud_rates[100] == round(2_000_000 / 101)
    assert (mx.baud_rates[250], mx.baud_rates[251], mx.baud_rates[252]) == (2_250_000, 2_500_000, 3_000_000)
    assert mx.baud_rates[0] == 2_000_000 and mx.baud_rates[249] == 8000 and 253 not in mx.baud_rates
    assert M(107).baud_rates == ax.baud_rates and M(360).baud_rates == mx.baud_rates


def test_status_error_bits_read_as_the_handlers_error_causes():
    from dynamixel_handler.servo import error_state
    ax = M(12)
    # Protocol 1.0: 0 input voltage, 1 angle limit, 2 overheating, 3 range, 4 checksum, 5 overload, 6 instruction;
    # input voltage, overheating and overload sit where the X layout has them, the rest are no hardware error
    assert error_state.common_bits(ax, 0x7F) == 0x25
    assert error_state.common_bits(ax, 0x24) == 0x24 and error_state.own_bits(ax, 0x25) == 0x25
    assert error_state.common_bits(ax, 0x1A) == 0  # angle limit, range, checksum


def test_currents_read_from_their_zero():
    mx64, ex = M(310), M(107)
    assert units.pulse_to_unit([mx64, mx64, ex], "present_current", [2048, 2148, 312]).tolist() == \
        pytest.approx([0.0, 450.0, -2000.0])  # 4.5 mA from 2048; 10 mA from 512 (the pages' examples)
    assert units.pulse_to_unit([mx64], "goal_current", [-100]).tolist() == pytest.approx([-450.0])
