"""The E-stop on a rig of its own per test (``test_e_stop.py`` shares one node; two nodes on one
domain would answer each other's calls): ``safety/on_hardware_error: hold_all``, the LEDs of
``led_status``, a reconnect of the adapter and a servo added while stopped."""
from __future__ import annotations

from std_msgs.msg import Bool
from test_e_stop import OVERLOAD, _at_rest, _set, _state_listener, _writes_to

from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelControlXVelocity, DynamixelShortcut

from support.rig import X540, P, Rig, X


def test_hold_all_engages_on_one_servos_overload_and_refuses_a_release_until_it_is_cleared():
    rig = Rig({1: X, 2: X540}, "safety/on_hardware_error:=hold_all", "pub_ratio/error:=1", "latency_timer:=16")
    try:
        rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[30.0]))
        rig.wait(lambda: rig.sim.servo(2).read("goal_velocity") > 0, what="ID 2 turning")
        mark = rig.mark()
        rig.sim.set_hardware_error(1, OVERLOAD)
        line = rig.wait_log("E-stop engaged (hardware error: ID 1 (XM430-W350)", since=mark)
        assert "overload" in line.lower() or "0x20" in line, line
        rig.wait(lambda: rig.sim.servo(2).read("goal_velocity") == 0, what="ID 2 held (goal velocity 0)")
        assert rig.sim.servo(2).read("torque_enable") == 1
        res = _set(rig, False)
        assert not res.success and "ID 1" in res.message and "hardware error" in res.message, res.message
        rig.publish("/dynamixel/e_stop", Bool(data=False))
        rig.wait_log("E-stop release (dynamixel/e_stop) refused", since=mark)
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="clear_error", id_list=[1]))
        rig.wait(lambda: rig.sim.servo(1).read("hardware_error_status") == 0, timeout=15, what="the error cleared")
        rig.wait(lambda: _set(rig, False).success, timeout=15, what="the release taken once the error is gone")
        assert rig.sim.servo(2).read("goal_velocity") == 0  # nothing moved by itself
    finally:
        assert rig.close() == 0


def test_led_status_shows_torque_the_e_stop_and_an_error_on_an_x_and_a_p_model():
    rig = Rig({1: X, 3: P}, "led_status:=true", "latency_timer:=16")

    def leds() -> tuple:
        p = rig.sim.servo(3)
        return rig.sim.servo(1).read("led"), (p.read("led_red"), p.read("led_green"), p.read("led_blue"))
    try:
        rig.wait(lambda: leds() == (0, (0, 255, 0)), what=f"torque on: X dark, P green (shows {leds()})")
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_off", id_list=[3]))
        rig.wait(lambda: leds() == (0, (0, 0, 255)), what=f"P torque off: blue (shows {leds()})")
        assert _set(rig, True).success
        rig.wait(lambda: leds() == (1, (255, 255, 0)), what=f"E-stop: X lit, P yellow (shows {leds()})")
        assert _set(rig, False).success
        rig.wait(lambda: leds() == (0, (0, 0, 255)), what=f"released: as before (shows {leds()})")
        at = len(rig.sim.log)
        rig.fresh_states(count=10)
        assert _writes_to(rig, at, "led", 1) == 0 and _writes_to(rig, at, "led_red", 3) == 0  # no change, no write
        rig.sim.set_hardware_error(3, OVERLOAD)
        rig.wait(lambda: leds()[1] == (255, 0, 0), timeout=15, what=f"P error: red (shows {leds()})")
        assert leds()[0] == 0
    finally:
        assert rig.close() == 0


def test_the_stop_survives_a_reconnect_of_the_adapter_and_holds_a_servo_added_later(tmp_path):
    rig = Rig({1: X, 2: X540}, "latency_timer:=16", sim_kwargs={"link": str(tmp_path / "ttyDXL")})
    try:
        states = _state_listener(rig)
        assert _set(rig, True).success
        rig.wait(lambda: states[-1:] == [True], what="engaged")
        rig.sim.vanish()
        rig.node_proc.wait_for("is gone (the port hung up", timeout=10)
        for dxl_id in (1, 2):  # the servos lost power with the adapter: torque off
            rig.sim.servo(dxl_id).write("torque_enable", 0)
        rig.sim.reappear()
        rig.node_proc.wait_for("is back: reconnected", timeout=10)
        rig.wait(lambda: all(rig.sim.servo(i).read("torque_enable") == 1 for i in (1, 2)), timeout=15,
                 what="the servos set up again (torque on, goal := present)")
        held = _at_rest(rig, 1)
        mark = rig.mark()
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[45.0]))
        rig.wait_log("E-stop engaged (dynamixel/set_e_stop): x/position_control refused", since=mark)
        assert _at_rest(rig, 1) == held and states[-1] is True

        rig.sim.add_servo(3, X)
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="add_id", id_list=[3]))
        rig.wait(lambda: 3 in list(rig.debug[-1].status.id_list), timeout=15, what="ID 3 handled")
        start = _at_rest(rig, 3)
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[3], position_deg=[90.0]))
        rig.fresh_states(count=5)
        assert _at_rest(rig, 3) == start  # refused: the stop holds the new servo too
        assert _set(rig, False).success
    finally:
        assert rig.close() == 0
