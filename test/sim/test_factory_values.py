"""Unboxed virtual servos hold the factory values of their own model, read over the wire with the
real dynamixel_sdk at the address the e-Manual gives. Each row names its e-Manual page
(ROBOTIS e-Manual, docs/en/dxl/<page>): "Initial Value" column of the control table."""

from __future__ import annotations

import pytest
from dynamixel_sdk import COMM_SUCCESS, PacketHandler

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.sim import VirtualBus

from support.sdk import PatientPort

# model number -> its ID on the test bus
ID_OF = {1020: 1, 1000: 2, 1060: 3, 1120: 4, 1150: 5, 1200: 6, 1220: 7, 1710: 8, 2020: 9, 2120: 10,
         53769: 11, 54024: 12, 35072: 13, 1090: 14}

# (model, item, address, size, factory value)
ROWS = [
    # x/xm430-w350
    (1020, "velocity_limit", 44, 4, 200), (1020, "current_limit", 38, 2, 1193),
    (1020, "max_voltage_limit", 32, 2, 160), (1020, "min_voltage_limit", 34, 2, 95),
    (1020, "position_p_gain", 84, 2, 800), (1020, "velocity_i_gain", 76, 2, 1920),
    # x/xh430-w350
    (1000, "velocity_limit", 44, 4, 130), (1000, "current_limit", 38, 2, 648), (1000, "position_p_gain", 84, 2, 900),
    # x/xl430-w250
    (1060, "temperature_limit", 31, 1, 72), (1060, "max_voltage_limit", 32, 2, 140),
    (1060, "min_voltage_limit", 34, 2, 60), (1060, "velocity_limit", 44, 4, 415),
    (1060, "velocity_i_gain", 76, 2, 1000), (1060, "position_d_gain", 80, 2, 4000),
    (1060, "position_p_gain", 84, 2, 640),
    # x/2xl430-w250
    (1090, "velocity_limit", 44, 4, 250), (1090, "velocity_i_gain", 76, 2, 1800),
    (1090, "position_d_gain", 80, 2, 2000),
    # x/xm540-w270
    (1120, "current_limit", 38, 2, 2047), (1120, "velocity_limit", 44, 4, 128),
    (1120, "external_port_mode_1", 56, 1, 3),
    # x/xh540-v150
    (1150, "max_voltage_limit", 32, 2, 300), (1150, "min_voltage_limit", 34, 2, 110),
    (1150, "velocity_limit", 44, 4, 230),
    # x/xl330-m288
    (1200, "temperature_limit", 31, 1, 70), (1200, "max_voltage_limit", 32, 2, 70),
    (1200, "min_voltage_limit", 34, 2, 35), (1200, "current_limit", 38, 2, 1750),
    (1200, "velocity_limit", 44, 4, 445), (1200, "shutdown", 63, 1, 53), (1200, "pwm_slope", 62, 1, 140),
    (1200, "velocity_i_gain", 76, 2, 1600), (1200, "velocity_p_gain", 78, 2, 180), (1200, "position_p_gain", 84, 2, 400),
    # x/xc330-t288
    (1220, "max_voltage_limit", 32, 2, 140), (1220, "min_voltage_limit", 34, 2, 55),
    (1220, "current_limit", 38, 2, 910), (1220, "velocity_limit", 44, 4, 320), (1220, "pwm_slope", 62, 1, 255),
    (1220, "shutdown", 63, 1, 52), (1220, "velocity_p_gain", 78, 2, 40), (1220, "position_p_gain", 84, 2, 900),
    # x/xm335-t323
    (1710, "max_position_limit", 48, 4, 3072), (1710, "min_position_limit", 52, 4, 1024),
    (1710, "temperature_limit", 31, 1, 70), (1710, "current_limit", 38, 2, 910),
    # p/ph54-200-s500-r
    (2020, "max_position_limit", 48, 4, 501433), (2020, "min_position_limit", 52, 4, -501433),
    (2020, "velocity_limit", 44, 4, 2900), (2020, "acceleration_limit", 40, 4, 9982),
    (2020, "current_limit", 38, 2, 22740), (2020, "shutdown", 63, 1, 52),
    (2020, "velocity_i_gain", 524, 2, 2209), (2020, "velocity_p_gain", 526, 2, 6153),
    (2020, "position_p_gain", 532, 2, 314),
    # p/pm54-060-s250-r
    (2120, "max_position_limit", 48, 4, 251173), (2120, "current_limit", 38, 2, 7980),
    (2120, "velocity_limit", 44, 4, 2830), (2120, "acceleration_limit", 40, 4, 11145),
    (2120, "shutdown", 63, 1, 58), (2120, "position_p_gain", 532, 2, 502),
    # pro/h54-100-s500-ra
    (53769, "moving_threshold", 24, 4, 50), (53769, "acceleration_limit", 40, 4, 10639),
    (53769, "velocity_limit", 44, 4, 2920), (53769, "max_position_limit", 48, 4, 501433),
    # pro/h54-200-s500-r (the shared old PRO table)
    (54024, "moving_threshold", 17, 4, 50), (54024, "max_voltage_limit", 22, 2, 400),
    (54024, "min_voltage_limit", 24, 2, 150), (54024, "shutdown", 48, 1, 58),
    (54024, "external_port_mode_1", 44, 1, 0),
    # pro/l42-10-s300-r
    (35072, "shutdown", 48, 1, 48),
]


@pytest.fixture(scope="module")
def wire():
    bus = VirtualBus({sid: number for number, sid in ID_OF.items()}, baudrate=1_000_000, wire_timing=False)
    bus.start()
    port = PatientPort(bus.path)
    assert port.openPort() and port.setBaudRate(1_000_000)
    yield port, PacketHandler(2.0)
    port.closePort()
    bus.close()


def _read(wire, sid: int, address: int, size: int, signed: bool = False) -> int:
    port, ph = wire
    data, result, error = ph.readTxRx(port, sid, address, size)
    assert (result, error) == (COMM_SUCCESS, 0)
    return int.from_bytes(bytes(data), "little", signed=signed)


@pytest.mark.parametrize("number,name,address,size,value", ROWS,
                         ids=[f"{model_by_number(r[0]).name}-{r[1]}" for r in ROWS])
def test_unboxed_servo_holds_the_manual_factory_value(wire, number, name, address, size, value):
    item = model_by_number(number).item(name)
    assert (item.address, item.size) == (address, size)
    assert _read(wire, ID_OF[number], address, size, item.signed) == value


def test_each_model_answers_at_its_own_id_with_its_model_number(wire):
    for number, sid in ID_OF.items():
        assert _read(wire, sid, 0, 2) == number
