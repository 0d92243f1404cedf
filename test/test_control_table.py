"""Control-table facts pinned against the ROBOTIS e-Manual."""

import math

import pytest

from dynamixel_handler.control_table import OPERATING_MODES, SERIES, Item, Model, known_models, model_by_number
from dynamixel_handler.control_table._sdk_files import load_sdk_table, sdk_model_index

OLD_PRO = (54024, 53768, 51200, 46352, 46096, 43288)
PRO_RA = (54025, 53769, 51201, 46353, 46097, 43289)
P_SERIES = (2000, 2010, 2020, 2100, 2110, 2120)


def addr(number: int, name: str):
    it = model_by_number(number).item(name)
    return it.address, it.size


def test_contract_constants():
    assert SERIES[:3] == ("X", "P", "PRO")  # families added later follow (test_table_y.py: Y)
    assert dict(OPERATING_MODES) == {"current": 0, "velocity": 1, "position": 3,
                                     "ex_position": 4, "cur_position": 5, "pwm": 16}


def test_every_protocol2_servo_in_the_sdk_index_is_known():
    ours = {m.number for m in known_models()}
    for number, file_name in sdk_model_index().items():
        if file_name.startswith(("x", "2x", "p", "h", "m")) and file_name not in (
                "xl320.model", "mx_28.model", "mx_64.model", "mx_106.model"):
            assert number in ours, (number, file_name)
    assert 1280 in ours  # XW430-T200: table file exists but the SDK index omits it
    for number in OLD_PRO + PRO_RA + P_SERIES:
        assert number in ours


def test_unknown_model_number_raises_clear_key_error():
    with pytest.raises(KeyError, match="unknown Dynamixel model number 1234"):
        model_by_number(1234)


def test_missing_item_raises_key_error_naming_the_model():
    with pytest.raises(KeyError, match="H54-200-S500-R.*goal_pwm"):
        model_by_number(54024).item("goal_pwm")


@pytest.mark.parametrize("number,name,expected", [
    (1020, "model_number", (0, 2)), (1020, "operating_mode", (11, 1)),
    (1020, "homing_offset", (20, 4)), (1020, "torque_enable", (64, 1)), (1020, "led", (65, 1)),
    (1020, "hardware_error_status", (70, 1)), (1020, "bus_watchdog", (98, 1)),
    (1020, "goal_current", (102, 2)), (1020, "goal_position", (116, 4)),
    (1020, "present_current", (126, 2)), (1020, "present_position", (132, 4)),
    (1020, "present_temperature", (146, 1)), (1020, "startup_configuration", (60, 1)),
    (1120, "external_port_mode_3", (58, 1)), (1120, "external_port_data_1", (152, 2)),
    (1200, "pwm_slope", (62, 1)), (1060, "present_load", (126, 2)),
    (2020, "torque_enable", (512, 1)), (2020, "led_red", (513, 1)),
    (2020, "present_position", (580, 4)), (2020, "goal_position", (564, 4)),
    (2020, "acceleration_limit", (40, 4)), (2020, "external_port_data_4", (606, 2)),
    (2020, "startup_configuration", (60, 1)),
    (54025, "present_position", (580, 4)), (54025, "hardware_error_status", (518, 1)),
    (54024, "homing_offset", (13, 4)), (54024, "current_limit", (30, 2)),
    (54024, "acceleration_limit", (26, 4)), (54024, "velocity_limit", (32, 4)),
    (54024, "shutdown", (48, 1)), (54024, "torque_enable", (562, 1)),
    (54024, "position_p_gain", (594, 2)), (54024, "goal_position", (596, 4)),
    (54024, "goal_velocity", (600, 4)), (54024, "goal_current", (604, 2)),
    (54024, "profile_acceleration", (606, 4)), (54024, "moving", (610, 1)),
    (54024, "present_position", (611, 4)), (54024, "present_velocity", (615, 4)),
    (54024, "present_current", (621, 2)), (54024, "present_input_voltage", (623, 2)),
    (54024, "external_port_data_1", (626, 2)), (54024, "hardware_error_status", (892, 1)),
    (43288, "goal_position", (596, 4)), (51200, "present_current", (621, 2)),
])
def test_addresses_match_the_manual(number, name, expected):
    assert addr(number, name) == expected


@pytest.mark.parametrize("number", OLD_PRO)
def test_old_pro_lacks_what_its_firmware_lacks(number):
    model = model_by_number(number)
    assert model.series == "PRO"
    for name in ("drive_mode", "goal_pwm", "present_pwm", "pwm_limit", "profile_velocity",
                 "position_d_gain", "position_i_gain", "feedforward_1st_gain", "bus_watchdog",
                 "moving_status", "velocity_trajectory", "realtime_tick"):
        assert not model.has(name), name
    assert model.has("goal_current") and model.has("position_p_gain")
    assert math.isnan(model.pwm_percent_per_pulse)


def test_sensorless_x_models_expose_load_not_current():
    for number in (1060, 1070, 1080, 1090, 1160):
        model = model_by_number(number)
        assert not model.has("present_current") and not model.has("goal_current")
        assert model.has("present_load")
        assert math.isnan(model.current_ma_per_pulse)


@pytest.mark.parametrize("number,ma", [
    (1020, 2.69), (1120, 2.69), (1040, 1.34), (1050, 1.34), (1200, 1.0), (1240, 1.0),
    (2020, 1.0), (54025, 1.0), (54024, 33000 / 2048), (46352, 33000 / 2048),
    (51200, 8250 / 2048), (43288, 8250 / 2048)])
def test_current_scale(number, ma):
    assert model_by_number(number).current_ma_per_pulse == pytest.approx(ma)


@pytest.mark.parametrize("number,rpm", [
    (1020, 0.229), (1200, 0.229), (2020, 0.01), (54025, 0.01), (54024, 0.00199234),
    (53768, 0.00199234), (51200, 0.00329218), (46352, 0.00397746), (46096, 0.00397746),
    (43288, 0.00389076)])
def test_velocity_scale_is_rpm_times_six(number, rpm):
    assert model_by_number(number).velocity_deg_s_per_pulse == pytest.approx(rpm * 6.0)


def test_acceleration_scales():
    assert model_by_number(1020).acceleration_deg_ss_per_pulse == pytest.approx(21.4577)
    assert model_by_number(2020).acceleration_deg_ss_per_pulse == pytest.approx(0.1)
    assert model_by_number(54025).acceleration_deg_ss_per_pulse == pytest.approx(0.1)
    # Old PRO: 58,000 rev/min^2 at the motor per LSB, divided by the gear ratio (1 / rpm scale).
    assert model_by_number(54024).acceleration_deg_ss_per_pulse == pytest.approx(
        58000 * 0.00199234 / 10)


def test_pwm_full_scale():
    assert 885 * model_by_number(1020).pwm_percent_per_pulse == pytest.approx(100.0)
    assert 2009 * model_by_number(2020).pwm_percent_per_pulse == pytest.approx(100.0)
    assert 2009 * model_by_number(54025).pwm_percent_per_pulse == pytest.approx(100.0)


@pytest.mark.parametrize("number,half_turn", [
    (2000, 303750), (2010, 501923), (2020, 501923), (2100, 263187), (2110, 251417),
    (2120, 251417), (54025, 501923), (51201, 303750), (46353, 251417), (43289, 263187),
    (54024, 250961), (53768, 250961), (51200, 151875), (46352, 125708), (46096, 125708),
    (43288, 131593)])
def test_p_and_pro_position_range(number, half_turn):
    model = model_by_number(number)
    assert model.position_max_pulse == half_turn and model.position_min_pulse == -half_turn
    assert model.position_zero_pulse == 0
    assert half_turn * model.position_deg_per_pulse == pytest.approx(180.0)


def test_our_half_turn_table_agrees_with_the_sdk_type_info():
    index = sdk_model_index()
    for model in known_models():
        # the RH-P12-RN(A) gripper has a stroke (0..1150 pulses), not a half turn around 0
        if model.series != "X" and model.number in index and model.position_min_pulse < 0:
            info = load_sdk_table(index[model.number]).type_info
            assert info["value_of_max_radian_position"] == model.position_max_pulse, model.name


def test_x_position_range():
    model = model_by_number(1020)
    assert (model.position_min_pulse, model.position_max_pulse, model.position_zero_pulse) == (0, 4095, 2048)
    assert model.position_deg_per_pulse == pytest.approx(360 / 4096)


def test_fixed_scales():
    model = model_by_number(1020)
    assert (model.voltage_v_per_pulse, model.temperature_degc_per_pulse,
            model.return_delay_us_per_pulse, model.bus_watchdog_ms_per_pulse,
            model.realtime_tick_s_per_pulse) == (0.1, 1.0, 2.0, 20.0, 0.001)


def test_external_ports():
    assert model_by_number(1120).external_ports == (1, 2, 3)   # XM540
    assert model_by_number(1101).external_ports == (1, 2, 3)   # XD540
    assert model_by_number(1170).external_ports == ()          # XW540 has none
    assert model_by_number(1020).external_ports == ()
    assert model_by_number(2020).external_ports == (1, 2, 3, 4)
    assert model_by_number(54024).external_ports == (1, 2, 3, 4)


@pytest.mark.parametrize("model", known_models(), ids=lambda m: m.name)
def test_every_table_is_consistent(model: Model):
    if model.layout == "Y":  # RAM items below 512 and an error code: test/control_table/test_table_y.py
        pytest.skip("DYNAMIXEL-Y tables are checked in test_table_y.py")
    boundary = 64 if model.series == "X" else (562 if model.number in OLD_PRO else 512)
    if model.layout == "XL320":
        boundary = 24  # its own table: RAM from Torque Enable (24)
    spans = []
    for name, it in model.items.items():
        assert isinstance(it, Item) and it.name == name
        assert it.size in (1, 2, 4)
        assert it.eeprom == (it.address < boundary), name
        spans.append((it.address, it.address + it.size, name))
    spans.sort()
    for (a0, a1, n0), (b0, _, n1) in zip(spans, spans[1:]):
        assert a1 <= b0, f"{model.name}: {n0} overlaps {n1}"
    for name in ("model_number", "id", "operating_mode", "torque_enable", "goal_position",
                 "present_position", "present_velocity", "hardware_error_status"):
        assert model.has(name), name


def test_signedness():
    x = model_by_number(1020)
    for name in ("goal_position", "present_position", "goal_velocity", "present_velocity",
                 "goal_current", "present_current", "goal_pwm", "present_pwm", "homing_offset",
                 "velocity_trajectory", "position_trajectory"):
        assert x.item(name).signed, name
    for name in ("velocity_limit", "profile_velocity", "profile_acceleration", "current_limit",
                 "pwm_limit", "moving_threshold", "realtime_tick", "id"):
        assert not x.item(name).signed, name
    assert model_by_number(2020).item("min_position_limit").signed  # default -501,923
    assert x.item("goal_position").min_raw == -(2 ** 31)
    assert x.item("profile_velocity").max_raw == 2 ** 32 - 1


def test_models_are_hashable_and_compare_by_number():
    assert model_by_number(1020) == model_by_number(1020)
    assert model_by_number(1020) != model_by_number(1030)
    assert len({model_by_number(1020), model_by_number(1020)}) == 1
    with pytest.raises(TypeError):
        model_by_number(1020).items["id"] = None  # read-only mapping


# ---------------------------------------------------------------------- models beyond the SDK index
@pytest.mark.parametrize("number,name,half_turn,rpm", [
    # e-Manual: resolution per turn / 2, Goal Velocity scale factor (rpm per LSB)
    (35072, "L42-10-S300-R", 2048, 0.114), (37896, "L54-30-S500-R", 180692, 0.00199234),
    (37928, "L54-30-S400-R", 144197, 0.00249657), (38152, "L54-50-S500-R", 180692, 0.00199234),
    (38176, "L54-50-S290-R", 103846, 0.00346667)])
def test_l_series_is_old_pro_with_its_own_scales(number, name, half_turn, rpm):
    model = model_by_number(number)
    assert (model.name, model.series, model.layout) == (name, "PRO", "OLD_PRO")
    assert model.position_max_pulse == half_turn
    assert model.position_deg_per_pulse == pytest.approx(180.0 / half_turn)
    assert model.velocity_deg_s_per_pulse == pytest.approx(rpm * 6.0)
    assert model.item("goal_position").address == 596 and model.item("present_current").address == 621
    assert model.indirect == ((49, 634, 256),)


def test_l42_offers_velocity_and_position_modes_only():
    assert model_by_number(35072).operating_modes == (1, 3)
    assert model_by_number(35072).current_ma_per_pulse == pytest.approx(8250 / 2048)


@pytest.mark.parametrize("number", PRO_RA)
def test_pro_ra_is_p_series(number):
    model = model_by_number(number)
    assert model.series == "P" and model.layout == "P"
    assert model.item("goal_position").address == 564
    assert model.baud_rates[9] == 10_500_000


def test_xm335_and_x330_tables():
    xm335 = model_by_number(1710)
    assert (xm335.name, xm335.series, xm335.layout) == ("XM335-T323", "X", "X330")
    assert xm335.current_ma_per_pulse == 1.0 and xm335.indirect == ((168, 224, 28),)
    assert xm335.item("backup_ready").address == 147 and 7 not in xm335.baud_rates
    for number in (1190, 1200, 1210, 1220, 1230, 1240):
        x330 = model_by_number(number)
        assert x330.layout == "X330" and x330.current_ma_per_pulse == 1.0
        assert x330.indirect_blocks(52) == ((168, 208, 20),)
        assert x330.indirect_blocks(48) == ((168, 224, 20),)   # data block before firmware v52
    xm430 = model_by_number(1020)
    assert xm430.indirect == ((168, 224, 28), (578, 634, 28)) and xm430.baud_rates[7] == 4_500_000
    assert model_by_number(2020).indirect == ((168, 634, 128),)
    assert model_by_number(1280).name == "XW430-T200" and model_by_number(1280).current_ma_per_pulse == 2.69


def test_every_model_carries_the_factory_values_of_its_manual_page():
    """Model.factory (control_table/_factory.py, one e-Manual page per model) is complete enough
    for an unboxed servo, and every value fits its item and the model's position range."""
    for model in known_models():
        if model.layout in ("Y", "XL320"):
            continue  # no Shutdown item / no Moving Threshold: test/control_table/test_table_{y,xl320}.py check their values
        factory = model.factory
        assert {"moving_threshold", "temperature_limit", "max_voltage_limit", "min_voltage_limit",
                "shutdown"} <= set(factory), model.name
        assert factory["min_voltage_limit"] < factory["max_voltage_limit"]
        for name, value in factory.items():
            item = model.item(name)
            assert item.min_raw <= value <= item.max_raw, (model.name, name)
        if model.layout == "OLD_PRO":
            continue  # the "-R" pages give no limits or gains
        assert {"velocity_limit", "max_position_limit", "min_position_limit", "pwm_limit"} <= set(factory)
        assert model.position_min_pulse <= factory["min_position_limit"] < factory["max_position_limit"] \
            <= model.position_max_pulse, model.name
        if model.series == "X":
            assert "position_p_gain" in factory and "velocity_i_gain" in factory, model.name


@pytest.mark.parametrize("number,name,value", [
    (1020, "velocity_limit", 200), (1030, "velocity_limit", 330),          # x/xm430-w350, x/xm430-w210
    (1040, "current_limit", 689), (1040, "max_voltage_limit", 300),       # x/xh430-v350
    (1060, "temperature_limit", 72),                                      # x/xl430-w250
    (1190, "position_i_gain", 400), (1190, "shutdown", 53),               # x/xl330-m077
    (1240, "current_limit", 2352),                                        # x/xc330-m288
    (1710, "baud_rate", 3), (1710, "velocity_limit", 280),               # x/xm335-t323
    (1710, "velocity_i_gain", 1800), (1710, "velocity_p_gain", 50), (1710, "position_p_gain", 2000),
    (1310, "current_limit", 1188),                                        # x/xw540-h260
    (2000, "max_position_limit", 303454),                                 # p/ph42-020-s300-r
    (2010, "acceleration_limit", 4255632),                                # p/ph54-100-s500-r
    (2100, "velocity_i_gain", 6740),                                      # p/pm42-010-s260-r
    (46353, "moving_threshold", 50),                                      # pro/m54-60-s250-ra
    (43288, "max_voltage_limit", 400),                                    # pro/m42-10-s260-r
])
def test_factory_values_match_the_manual(number, name, value):
    assert model_by_number(number).factory[name] == value


def test_the_xc335_table_is_its_model_file():
    """xc335_t332.model (ROBOTIS' dynamixel_hardware_interface): Startup Configuration 2 bytes at 60,
    no Backup Ready; the XM335-T323 page has both as the X330 pages (1 byte, 147)."""
    xc335, xm335 = model_by_number(1700), model_by_number(1710)
    assert (xc335.item("startup_configuration").address, xc335.item("startup_configuration").size) == (60, 2)
    assert not xc335.has("backup_ready")
    assert xm335.item("startup_configuration").size == 1 and xm335.has("backup_ready")


def test_no_factory_value_where_the_manual_gives_none():
    assert "velocity_limit" not in model_by_number(54024).factory   # old PRO: "-"
    assert "position_p_gain" not in model_by_number(54025).factory  # PRO(A): gains "-"
    assert "current_limit" not in model_by_number(1060).factory     # XL430: no such item
