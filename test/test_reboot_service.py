"""``dynamixel/reboot`` (std_srvs/Trigger) through the real node on the virtual bus: only the
servos in hardware error are rebooted (the reboot instructions on the bus counted), their settings
and torque come back, each is named with its outcome; with none in error nothing is touched."""
from __future__ import annotations

from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from dynamixel_handler.protocol import REBOOT

from support.rig import X540, Rig, X

OVERLOAD = 0x20


def _call(rig: Rig, srv_type, name: str, request, timeout: float = 40.0):
    return rig.call(srv_type, name, request, timeout)


def _reboots(rig: Rig, since: int) -> list[tuple[int, ...]]:
    return [e.ids for e in rig.sim.log[since:] if e.instruction == REBOOT]


def test_only_the_servo_in_error_is_rebooted_and_gets_its_settings_and_torque_back():
    rig = Rig({1: X, 2: X540, 3: X}, "servos.id_2.position_p_gain_pulse:=900", "latency_timer:=16")
    try:
        rig.wait(lambda: rig.sim.servo(2).read("position_p_gain") == 900, what="the servos block's gain")
        at = len(rig.sim.log)
        res = _call(rig, Trigger, "/dynamixel/reboot", Trigger.Request())
        assert res.success and "no servo has a hardware error" in res.message, res.message
        assert _reboots(rig, at) == []  # a healthy servo is never rebooted

        rig.sim.set_hardware_error(2, OVERLOAD)  # the servo drops its torque, the RAM keeps the gain
        rig.wait(lambda: rig.debug_of(2)["error"], what="ID 2's error published")
        rig.sim.servo(2).write("position_p_gain", 800)  # as if lost: the reboot must put the file's back
        at = len(rig.sim.log)
        res = _call(rig, Trigger, "/dynamixel/reboot", Trigger.Request())
        assert res.success, res.message
        assert res.message == "ID 2 (XM540-W270): rebooted, error gone, torque on", res.message
        assert _reboots(rig, at) == [(2,)]
        servo = rig.sim.servo(2)
        assert servo.read("hardware_error_status") == 0 and servo.read("torque_enable") == 1
        assert servo.read("position_p_gain") == 900
        assert all(rig.sim.servo(i).read("torque_enable") == 1 for i in (1, 3))
    finally:
        assert rig.close() == 0


def test_a_reboot_is_carried_out_while_the_e_stop_holds_the_others():
    rig = Rig({1: X, 2: X540}, "latency_timer:=16")
    try:
        with rig._lock:
            pub = rig.node.create_publisher(Bool, "/dynamixel/e_stop", 10)
        res = _call(rig, SetBool, "/dynamixel/set_e_stop", SetBool.Request(data=True))
        assert res.success, res.message
        rig.sim.set_hardware_error(1, OVERLOAD)
        rig.wait(lambda: rig.debug_of(1)["error"], what="ID 1's error published")
        at = len(rig.sim.log)
        res = _call(rig, Trigger, "/dynamixel/reboot", Trigger.Request())
        assert res.success and res.message.startswith("ID 1 (XM430-W350): rebooted, error gone"), res.message
        assert _reboots(rig, at) == [(1,)]
        pub.publish(Bool(data=False))
    finally:
        assert rig.close() == 0
