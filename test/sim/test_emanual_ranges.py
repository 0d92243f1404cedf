"""The virtual bus answers a value beyond the e-Manual range of the servo's model with a Data Range
Error and keeps the register (the model's ``value_range``: the data the set-up tool checks against),
driven by the real ``dynamixel_sdk``; the manual's bound itself is written."""

import pytest
from dynamixel_sdk import COMM_SUCCESS

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.protocol import servo as p

XM430, XL330, PH54 = 1020, 1200, 2020

# model, (item, address, size, the e-Manual's bound, a value beyond it)
CASES = [
    (XM430, "velocity_limit", 44, 4, 1023, 1024),
    (XM430, "max_voltage_limit", 32, 2, 160, 161),
    (XM430, "min_voltage_limit", 34, 2, 95, 94),
    (XM430, "position_p_gain", 84, 2, 16383, 16384),
    (XM430, "current_limit", 38, 2, 1193, 1194),
    (XL330, "velocity_limit", 44, 4, 2047, 2048),
    (XL330, "min_voltage_limit", 34, 2, 31, 30),
    (XL330, "velocity_i_gain", 76, 2, 16383, 16384),
    (PH54, "velocity_limit", 44, 4, 2900, 2901),
    (PH54, "max_voltage_limit", 32, 2, 350, 351),
    (PH54, "position_p_gain", 532, 2, 32767, 32768),
    (PH54, "acceleration_limit", 40, 4, 3_992_644, 3_992_645),
    (PH54, "moving_threshold", 24, 4, 2900, 2901),
]


@pytest.mark.parametrize("number,item,address,size,bound,beyond", CASES,
                         ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_a_value_beyond_the_e_manual_range_is_a_data_range_error(make_bus, make_sdk, number, item, address, size,
                                                                 bound, beyond):
    assert bound in model_by_number(number).value_range(item)
    bus = make_bus({1: number})
    port, ph = make_sdk(bus.path)
    write = {1: ph.write1ByteTxRx, 2: ph.write2ByteTxRx, 4: ph.write4ByteTxRx}[size]
    before = bus.servo(1).read(item)
    assert write(port, 1, address, beyond) == (COMM_SUCCESS, p.ERR_DATA_RANGE)
    assert bus.servo(1).read(item) == before
    assert write(port, 1, address, bound) == (COMM_SUCCESS, 0)
    assert bus.servo(1).read(item) == bound
