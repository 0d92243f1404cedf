"""Protocol 1.0 servos (AX-12A, MX-28 and MX-64 with the 1.0 firmware) beside a Protocol 2.0 one
on one bus, through the real node on the virtual bus, driven through the series-independent topics.

The expected registers are written out from the e-Manual's AX-12A and MX pages (not taken from the
product's tables): AX positions 0..1023 over 300 deg with 512 in the middle, MX 0..4095 over a turn
with 2048 in the middle; Moving Speed 0.111 rpm a unit (AX), 0.114 rpm (MX), bit 10 the direction
(set: clockwise, negative here); Wheel Mode = both Angle Limits (6, 8) 0, multi-turn = both 4095.
"""
from __future__ import annotations

import pytest

from dynamixel_handler_msgs.msg import DynamixelGoal, DynamixelShortcut, DynamixelStatus
from dynamixel_handler_msgs.srv import MoveTo, SetTorque

from support.rig import Rig

AX12A, AX18A, MX28, MX64, EX106, XM430 = 12, 18, 29, 310, 107, 1020
AX, AX_18, EX, MX, MX_64, X = 4, 2, 3, 5, 6, 1
AX_DEG, MX_DEG = 300.0 / 1023.0, 360.0 / 4096.0
AX_DEG_S, MX_DEG_S = 0.111 * 6.0, 0.114 * 6.0
CW = 1 << 10


@pytest.fixture(scope="module")
def rig():
    r = Rig({X: XM430, AX: AX12A, AX_18: AX18A, EX: EX106, MX: MX28, MX_64: MX64}, "baudrate:=1000000",
            "init/used_servo_series.AX:=true", "init/used_servo_series.EX:=true", "init/used_servo_series.MX1:=true",
            "mode_change_interval_sec:=0.0", "pub_ratio/status:=3", "pub_ratio/goal:=3", "pub_ratio/error:=3",
            "pub_ratio/extra.static_items:=3", "clear_error_interval_sec:=0.0",
            sim_kwargs={"baudrate": 1_000_000})
    # what the start-up found, before any test's command changes it (any order)
    ids = (AX, AX_18, EX, MX, MX_64, X)
    for dxl_id in ids:
        r.wait(lambda i=dxl_id: r.state_of("status", "mode", i) is not None, what=f"status of ID {dxl_id}")
    r.at_start = {i: (r.state_of("status", "mode", i), servo(r, i).read("torque_enable")) for i in ids}
    yield r
    assert r.close() == 0


def servo(rig: Rig, dxl_id: int):
    return rig.sim.servos_at(dxl_id)[0]


def wait_items(rig: Rig, dxl_id: int, expected: dict[str, int]) -> None:
    def now() -> dict[str, int]:
        return {name: servo(rig, dxl_id).read(name) for name in expected}
    try:
        rig.wait(lambda: now() == expected, what=f"ID {dxl_id} items {expected}")
    except AssertionError:
        assert now() == expected


def test_each_is_handled_beside_the_protocol2_servo(rig):
    for dxl_id, name in ((AX, "AX-12A"), (AX_18, "AX-18A"), (EX, "EX-106+"), (MX, "MX-28"), (MX_64, "MX-64")):
        assert f"ID {dxl_id}: {name}" in rig.output and "Protocol 1.0) handled" in rig.output, rig.output
        # joint mode, torque on (as init/torque_auto_enable says)
        assert rig.at_start[dxl_id] == ("position", 1), dxl_id
    assert rig.at_start[X][0] == "position"


@pytest.mark.parametrize("dxl_id, deg_per_pulse, zero", [(AX, AX_DEG, 512), (MX, MX_DEG, 2048),
                                                         (EX, 250.92 / 4095.0, 2048)])
def test_a_goal_in_degrees_is_written_and_reached(rig, dxl_id, deg_per_pulse, zero):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[dxl_id], mode=["position"], torque=[True]))
    rig.wait(lambda: rig.state_of("status", "mode", dxl_id) == "position", what=f"ID {dxl_id} in joint mode")
    # a speed of its own: another test may leave Moving Speed at its slowest
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[dxl_id], position_deg=[30.0], profile_vel_deg_s=[200.0]))
    wait_items(rig, dxl_id, {"goal_position": zero + round(30.0 / deg_per_pulse)})
    rig.wait(lambda: abs((rig.state_of("present", "position_deg", dxl_id) or 0.0) - 30.0) < 2.0,
             what=f"ID {dxl_id} at 30 deg", timeout=15.0)


def test_wheel_mode_and_back_keeps_the_joint_limits(rig):
    servo(rig, AX).write("max_position_limit", 1000)       # an owner's joint range
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[AX], mode=["position"]))  # reads it again
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[AX], mode=["velocity"]))
    wait_items(rig, AX, {"min_position_limit": 0, "max_position_limit": 0})
    rig.wait(lambda: rig.state_of("status", "mode", AX) == "velocity", what="AX in wheel mode")
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[AX], velocity_deg_s=[-20.0]))
    wait_items(rig, AX, {"goal_velocity": -round(20.0 / AX_DEG_S)})     # the virtual servo reads bit 10 as the sign
    raw = servo(rig, AX).host_read(32, 2)[1]                                  # Moving Speed as on the wire
    assert int.from_bytes(raw, "little") == CW + round(20.0 / AX_DEG_S)
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[AX], mode=["position"]))
    wait_items(rig, AX, {"min_position_limit": 0, "max_position_limit": 1000})
    rig.wait(lambda: rig.state_of("status", "mode", AX) == "position", what="AX in joint mode again")


def test_multi_turn_on_the_mx(rig):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[MX], mode=["ex_position"]))
    wait_items(rig, MX, {"min_position_limit": 4095, "max_position_limit": 4095})
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[MX], position_deg=[540.0]))
    wait_items(rig, MX, {"goal_position": 2048 + round(540.0 / MX_DEG)})


def test_overheating_is_published_and_cleared_the_protocol1_way(rig):
    """The error byte of the statuses reads as the error state; the clear writes Torque Limit back
    (the servo set it to 0, as its Shutdown bits say) and no reboot is sent."""
    ax = servo(rig, AX)
    assert ax.read("torque_limit") > 0
    ax.pin("present_temperature", ax.read("temperature_limit") + 5)
    rig.wait(lambda: rig.state_of("error", "overheating", AX) is True, what="error.overheating of the AX")
    assert rig.state_of("error", "overload", AX) is False and rig.state_of("error", "input_voltage", AX) is False
    rig.wait(lambda: rig.state_of("status", "error", AX) is True, what="status.error of the AX")
    assert ax.read("torque_limit") == 0                                     # its output cut
    ax.pin("present_temperature", None)
    ax.write("led", 1)                                                     # RAM: a reboot would clear it
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[AX]))
    wait_items(rig, AX, {"torque_limit": ax.read("pwm_limit"), "torque_enable": 1})
    rig.wait(lambda: rig.state_of("status", "error", AX) is False, what="status.error of the AX cleared")
    assert "(Torque Limit written back to 1023: cleared, no reboot)" in rig.output
    assert ax.read("led") == 1                                             # no reboot


def test_current_control_on_the_mx64(rig):
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[MX_64], mode=["current"]))
    wait_items(rig, MX_64, {"torque_control_mode_enable": 1})
    rig.wait(lambda: rig.state_of("status", "mode", MX_64) == "current", what="MX-64 in current control")
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[MX_64], current_ma=[-90.0]))
    wait_items(rig, MX_64, {"goal_current": -round(90.0 / 4.5)})       # Goal Torque: 4.5 mA a unit, bit 10 the sign
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[MX_64], mode=["position"]))
    wait_items(rig, MX_64, {"torque_control_mode_enable": 0})


def test_a_speed_of_zero_in_joint_mode_is_never_written_as_zero(rig):
    rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[MX], profile_vel_deg_s=[0.0], position_deg=[10.0]))
    wait_items(rig, MX, {"goal_velocity": 1, "goal_position": 2048 + round(10.0 / MX_DEG)})
    rig.wait_log("Moving Speed 0 would move it as fast as the motor goes")


def test_move_to_and_set_torque_services_drive_an_ax(rig):
    """The services go through the same core: move_to with a speed (Moving Speed in Joint Mode)
    waits until the AX is there; set_torque turns it off and on without a jump."""
    def call(srv_type, name, request):
        with rig._lock:
            client = rig.node.create_client(srv_type, name)
        assert client.wait_for_service(timeout_sec=10)
        future = client.call_async(request)
        rig.wait(future.done, timeout=30, what=f"the answer of {name}")
        return future.result()

    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[AX], mode=["position"]))
    rig.wait(lambda: rig.state_of("status", "mode", AX) == "position", what="AX in joint mode")
    res = call(MoveTo, "/dynamixel/move_to", MoveTo.Request(ids=[AX], positions_deg=[-40.0], profile_vel_deg_s=60.0,
                                                         wait=True, tolerance_deg=1.0, timeout_s=15.0))
    assert res.success and res.reached, res.message
    assert abs((servo(rig, AX).read("present_position") - 512) * AX_DEG - -40.0) <= 1.0
    assert servo(rig, AX).read("goal_velocity") == round(60.0 / AX_DEG_S)   # the speed of the move
    assert call(SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[AX], enable=False)).success
    wait_items(rig, AX, {"torque_enable": 0})
    assert call(SetTorque, "/dynamixel/set_torque", SetTorque.Request(ids=[AX], enable=True)).success
    wait_items(rig, AX, {"torque_enable": 1})
    assert abs(servo(rig, AX).read("goal_position") - servo(rig, AX).read("present_position")) <= 2  # no jump


def test_an_overload_is_published_and_cleared_without_a_reboot(rig):
    """A load beyond the AX-18A's Torque Limit latches the overload bit; its Shutdown bits cut the
    output; once the load is gone the clear writes Torque Limit back and the error goes."""
    ax = servo(rig, AX_18)
    ax.shaft.external_load = 1.5                                            # 150 % of its full output
    rig.wait(lambda: rig.state_of("error", "overload", AX_18) is True, what="error.overload of the AX-18A")
    wait_items(rig, AX_18, {"torque_limit": 0})
    ax.shaft.external_load = 0.0
    ax.write("led", 1)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[AX_18]))
    wait_items(rig, AX_18, {"torque_limit": ax.read("pwm_limit"), "torque_enable": 1})
    rig.wait(lambda: rig.state_of("error", "overload", AX_18) is False, what="error.overload cleared")
    assert ax.read("led") == 1                                             # no reboot


def test_a_bus_of_ax_servos_at_a_protocol1_only_rate_is_driven():
    """500,000 bps (Baud Rate 3) is a rate no Protocol 2.0 servo takes: the node opens the line at it."""
    r = Rig({AX: AX12A, AX_18: AX18A}, "baudrate:=500000", "init/used_servo_series.AX:=true",
            "init/used_servo_series.X:=false", sim_kwargs={"baudrate": 500_000})
    try:
        assert r.sim.servos_at(AX)[0].read("baud_rate") == 3
        assert f"ID {AX}: AX-12A" in r.output and f"ID {AX_18}: AX-18A" in r.output, r.output
        r.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[AX], position_deg=[20.0]))
        r.wait(lambda: r.sim.servos_at(AX)[0].read("goal_position") == 512 + round(20.0 / AX_DEG),
               what="the AX's goal written at 500 kbps")
    finally:
        assert r.close() == 0


def test_two_servos_at_one_id_are_named_in_protocol_1_and_across_the_protocols():
    """Two AX-12A at ID 3 (their replies collide): named and not handled; an MX-28 (1.0) at the ID
    of an XM430 (2.0): named, the XM430 handled (the protocols do not collide)."""
    def crowd(sim) -> None:
        sim.add_servo(3, AX12A)
        sim.add_servo(4, XM430)

    # a 16 ms adapter wait: a loaded host delayed the XM430's reply past 1 ms, so the scan found only
    # the MX-28 at ID 4 (which servo an ID holds is what the scan's replies say)
    r = Rig({1: AX12A, 3: AX12A, 4: MX28}, "baudrate:=1000000", "init/used_servo_series.AX:=true",
            "init/used_servo_series.MX1:=true", "latency_timer:=16", sim_kwargs={"baudrate": 1_000_000},
            before_start=crowd, expect=2, wait_ids=[1, 4])
    try:
        shared = r.wait_log("ID 3: two or more servos answer at this ID")
        assert "not handled" in shared
        across = r.wait_log("ID 4: a MX-28 answers Protocol 1.0 at the ID of the XM430-W350 (Protocol 2.0)")
        assert "the XM430-W350 is handled, the Protocol 1.0 servo is not" in across
        assert "ID 1: AX-12A" in r.output and "ID 4: XM430-W350" in r.output and "ID 3: AX-12A" not in r.output
        assert r.output.count("two or more servos answer at this ID") == 1  # once, whatever the scans
    finally:
        assert r.close() == 0
