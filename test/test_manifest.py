"""``dynamixel/manifest`` through the real node on the virtual bus: a subscriber that comes late
gets what each servo is and how it is set at once (latched), and a change is published again."""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from dynamixel_handler_msgs.msg import DynamixelStatus

from support.rig import X540, Rig, X

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _values(msg: DiagnosticArray, dxl_id: int) -> dict[str, str]:
    status = next(s for s in msg.status if s.hardware_id == f"ID {dxl_id}")
    return {v.key: v.value for v in status.values}


def test_a_late_subscriber_gets_the_manifest_and_a_mode_change_sends_it_again():
    rig = Rig({1: X, 2: X540}, "joint_state.use:=true", "joint_state.names:=[pan, tilt]", "joint_state.ids:=[1, 2]",
              "servos.id_2.position_p_gain_pulse:=900")
    try:
        rig.fresh_states(count=5)
        got: list[DiagnosticArray] = []
        with rig._lock:  # subscribes after the node published its manifest
            rig.node.create_subscription(DiagnosticArray, "/dynamixel/manifest", got.append, LATCHED)
        rig.wait(lambda: len(got) >= 1, timeout=10, what="the manifest, latched")
        one, two = _values(got[-1], 1), _values(got[-1], 2)
        assert one["model"] == "XM430-W350" and one["model_number"] == "1020" and one["protocol"] == "2.0", one
        assert one["joint"] == "pan" and two["joint"] == "tilt" and one["baudrate"] == "57600", one
        assert one["operating_mode"] == "position" and two["position_p_gain"] == "900", two
        assert "firmware_version" in one and "max_position_limit [deg]" in one and "profile_velocity [deg/s]" in one
        assert float(one["max_position_limit [deg]"]) > 0.0

        count = len(got)
        rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], mode=["velocity"]))
        rig.wait(lambda: len(got) > count and _values(got[-1], 1)["operating_mode"] == "velocity", timeout=10,
                 what="a new manifest with ID 1 in velocity mode")
        assert _values(got[-1], 2)["operating_mode"] == "position"
    finally:
        assert rig.close() == 0
