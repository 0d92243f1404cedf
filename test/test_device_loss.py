"""The adapter vanishes (unplugged, or its power gone with the servos'): the device is gone, not the
servos. Nothing counts towards a servo's removal meanwhile, and once the device is back every servo
handled before is pinged and set up again as at start-up."""
from __future__ import annotations

import time

from dynamixel_handler_msgs.msg import DynamixelControlXPosition

from support.rig import X540, Rig, X


def test_a_vanished_adapter_removes_no_servo_and_its_servos_are_set_up_again_when_it_is_back(tmp_path):
    # a 16 ms latency timer: three replies the virtual bus, starved on a loaded host, sends later than
    # a 1 ms timer's ~4 ms wait would remove a servo the test expects kept
    rig = Rig({1: X, 2: X540}, "no_response_id_auto_remove_count:=3", "pub_ratio/status:=1", "latency_timer:=16",
              sim_kwargs={"link": str(tmp_path / "ttyDXL")})
    try:
        servos = [rig.sim.servo(i) for i in (1, 2)]
        profiles = [s.read("profile_velocity") for s in servos]
        assert all(profiles) and all(s.read("torque_enable") == 1 for s in servos)
        mark = rig.mark()
        rig.sim.vanish()
        rig.node_proc.wait_for("is gone (the port hung up", timeout=10)
        time.sleep(1.5)  # ~150 loops without the device: far more than 3 unanswered requests
        # the servos lost power with the adapter: RAM at its defaults, torque off
        for servo in servos:
            servo.write("torque_enable", 0)
            servo.write("profile_velocity", 0)
        rig.sim.reappear()
        rig.node_proc.wait_for("is back: reconnected", timeout=10)
        rig.wait(lambda: list(rig.debug[-1].status.id_list) == [1, 2] and all(rig.debug[-1].status.ping),
                 timeout=10, what="both servos handled and answering after the reconnect")
        rig.wait(lambda: [s.read("profile_velocity") for s in servos] == profiles
                 and all(s.read("torque_enable") == 1 for s in servos), timeout=10,
                 what="the start-up set-up again (profiles, torque on)")
        log = rig.log_since(mark)
        assert "removed" not in log, log
        # one line says the device is gone; none per servo while it is
        assert "no response (ping false)" not in log.split("is back: reconnected")[0], log
        rig.wait_log("after the reconnect: 2 servo(s) [1, 2] answer and are set up as at start-up", since=mark)
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[2], position_deg=[30.0]))
        rig.wait(lambda: abs(rig.debug_of(2)["position"] - 30.0) < 0.5, timeout=15, what="commands work after it")
    finally:
        assert rig.close() == 0


def test_a_reconnect_puts_back_the_profile_the_owner_set_not_the_start_value_and_says_what_changed(tmp_path):
    from dynamixel_handler_msgs.msg import DynamixelGoal
    rig = Rig({1: X}, "pub_ratio/goal:=1", "pub_ratio/limit:=1", sim_kwargs={"link": str(tmp_path / "ttyDXL")})
    try:
        servo = rig.sim.servo(1)
        rig.publish("/dynamixel/command/goal", DynamixelGoal(id_list=[1], profile_vel_deg_s=[20.0]))
        slow = round(20.0 / (0.229 * 6))
        rig.wait(lambda: servo.read("profile_velocity") == slow, what="the owner's profile velocity")
        limit = servo.read("velocity_limit")
        rig.fresh_states(3)  # the limit group read since
        mark = rig.mark()
        rig.sim.vanish()
        rig.node_proc.wait_for("is gone (the port hung up", timeout=10)
        servo.write("torque_enable", 0)  # power gone with the adapter, and the servo's limit changed meanwhile
        servo.write("profile_velocity", 0)
        servo.write("velocity_limit", limit - 100)
        rig.sim.reappear()
        rig.wait_log("ID 1: as before the device went:", since=mark, timeout=15)
        assert servo.read("profile_velocity") == slow  # not the 1000 deg/s start value
        rig.wait(lambda: servo.read("torque_enable") == 1, what="torque on again")
        line = rig.wait_log("EEPROM differs from before the device went", since=mark)
        assert f"velocity_limit {limit} -> {limit - 100}" in line
    finally:
        assert rig.close() == 0
