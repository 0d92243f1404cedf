"""Any control-table item read or written through the running node (``dynamixel/get_items``,
``dynamixel/set_items``) on the virtual bus, an X servo and an AX-12A (Protocol 1.0) side by side:
values in their units and raw, registers read back on the virtual servos, the set-up tool's checks
(range, limit pairs, protections with force, EEPROM with torque on only with torque_off), the
items the node keeps for its own doors refused, the loop's states going on meanwhile, and a read
while the adapter is gone answered at once."""
from __future__ import annotations

import math
import time

import pytest

from dynamixel_handler_msgs.srv import GetItems, SetItems

from support.rig import Rig

XM430, AX12A = 1020, 12


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: XM430, 2: XM430, 4: AX12A}, "baudrate:=1000000", "init/used_servo_series.AX:=true",
            sim_kwargs={"baudrate": 1_000_000})
    yield r
    assert r.close() == 0


def get(rig, ids, items, **kw) -> GetItems.Response:
    return rig.call(GetItems, "/dynamixel/get_items", GetItems.Request(ids=ids, items=items, **kw))


def set_items(rig, ids, items, values, **kw) -> SetItems.Response:
    return rig.call(SetItems, "/dynamixel/set_items", SetItems.Request(ids=ids, items=items, values=values, **kw))


def test_items_of_both_protocols_are_read_in_their_units_and_raw(rig):
    res = get(rig, [1, 4], ["present_temperature", "firmware_version", "temperature_limit", "shutdown"])
    assert res.success, res.message
    assert list(res.id_list) == [1] * 4 + [4] * 4 and list(res.item_list[:4]) == ["present_temperature", "firmware_version",
                                                                                   "temperature_limit", "shutdown"]
    got = {(i, n): (v, r, u) for i, n, v, r, u in zip(res.id_list, res.item_list, res.values, res.raw, res.units)}
    for dxl_id in (1, 4):
        servo = rig.sim.servos_at(dxl_id)[0]
        assert got[(dxl_id, "temperature_limit")][1] == servo.read("temperature_limit")
        assert got[(dxl_id, "temperature_limit")][2] == "degC"
        assert got[(dxl_id, "shutdown")][1] == servo.read("shutdown") and math.isnan(got[(dxl_id, "shutdown")][0])
    assert got[(1, "temperature_limit")][0] == 80.0 and got[(4, "temperature_limit")][0] == 70.0  # factory values


def test_a_ram_and_an_eeprom_item_are_written_in_units_and_read_back_and_torque_comes_back(rig):
    res = set_items(rig, [1], ["profile_velocity", "position_p_gain"], [30.0, 700.0])
    assert res.success, res.message
    servo = rig.sim.servo(1)
    assert servo.read("position_p_gain") == 700 and abs(res.values[0] - 30.0) < 0.3
    # an EEPROM item of a servo holding torque: only with torque_off, and torque comes back on
    assert servo.read("torque_enable") == 1
    res = set_items(rig, [1], ["temperature_limit"], [70.0])
    assert not res.success and "give torque_off" in res.errors[0] and servo.read("temperature_limit") == 80
    res = set_items(rig, [1], ["temperature_limit"], [70.0], torque_off=True)
    assert res.success, res.message
    assert servo.read("temperature_limit") == 70 and servo.read("torque_enable") == 1 and res.values[0] == 70.0
    # the Protocol 1.0 servo, raw
    res = set_items(rig, [4], ["cw_compliance_slope"], [64.0], raw=True)
    assert res.success and rig.sim.servos_at(4)[0].read("cw_compliance_slope") == 64, res.message


def test_the_set_up_tool_s_checks_refuse_with_the_reason_per_item_and_write_nothing_of_that_servo(rig):
    servo = rig.sim.servo(2)
    gain = servo.read("position_p_gain")
    cases = [
        (["temperature_limit"], [100.0], {}, "lowers a protection beyond its factory value"),
        (["min_position_limit", "max_position_limit"], [90.0, -90.0], {"torque_off": True}, "would not be below"),
        (["temperature_limit"], [500.0], {}, "out of range"),
        (["goal_position"], [10.0], {}, "a goal: give it on the command topics"),
        (["id"], [7.0], {}, "changes the bus under the node"),
        (["operating_mode"], [1.0], {"raw": True}, "the mode: the command topics"),
        (["no_such_item"], [1.0], {}, "has no control-table item 'no_such_item'"),
    ]
    for items, values, kw, why in cases:
        res = set_items(rig, [2], items + ["position_p_gain"], values + [gain + 10.0], **kw)
        assert not res.success and why in res.errors[0], (items, res.errors)
        assert res.errors[-1] == "not written: another item of this servo was refused"
        assert servo.read("position_p_gain") == gain  # nothing of the servo written
    res = set_items(rig, [2], ["temperature_limit"], [85.0], force=True, torque_off=True)
    assert res.success and servo.read("temperature_limit") == 85, res.message
    set_items(rig, [2], ["temperature_limit"], [80.0], torque_off=True)


def test_a_request_that_cannot_be_right_is_refused_at_once(rig):
    assert "no item named" in get(rig, [1], []).message
    assert "named twice" in get(rig, [1], ["led", "led"]).message
    res = set_items(rig, [1, 2], ["led", "position_p_gain"], [1.0, 2.0, 3.0])
    assert not res.success and "3 values for 2 items of 2 servos" in res.message
    res = get(rig, [9], ["led"])
    assert not res.success and res.errors[0] == "not handled by this node"


def test_the_loop_keeps_publishing_while_a_long_read_is_answered(rig):
    items = ["present_temperature", "present_input_voltage", "firmware_version", "temperature_limit",
             "max_voltage_limit", "min_voltage_limit", "return_delay_time", "shutdown"]
    start = time.monotonic()
    res = get(rig, [1, 2, 4], items * 1 + ["led"])
    assert res.success and len(res.values) == 27, res.message
    assert len(rig.states.since(start)) >= 2  # states went on while the 27 reads were done


def test_a_read_while_the_adapter_is_gone_is_answered_at_once_with_the_reason(rig):
    mark = rig.mark()
    rig.sim.vanish()
    try:
        rig.wait_log("is gone", since=mark)
        start = time.monotonic()
        res = get(rig, [1], ["present_temperature"])
        assert not res.success and "the bus device is gone" in res.message, res.message
        assert time.monotonic() - start < 5.0
    finally:
        rig.sim.reappear()
        rig.wait_log("is back: reconnected", since=mark, timeout=20)
