"""Two handlers in two namespaces, each on its own virtual bus with its own parameters, side by side."""
from __future__ import annotations

import threading
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelDebug
from dynamixel_handler_msgs.srv import SetTorque

from support.ros import SCAN_RETRIES, NodeProcess, node_command

X = 1020  # XM430-W350

# one parameter file for the robot: the shipped defaults, then a section per handler
ROBOT_YAML = """\
/left/dynamixel_handler:
  ros__parameters:
    device_name: {left}
    latency_timer: 1
    verbose_ratio: 0
    init/servo_auto_search: {{min_id: 1, max_id: 3, retry_times: {retries}}}
    init/expected_servo_num: 2
    joint_state: {{use: true, names: [left_shoulder, left_elbow], ids: [1, 2]}}
    diagnostics: {{period_sec: 0.3}}
/right/dynamixel_handler:
  ros__parameters:
    device_name: {right}
    latency_timer: 1
    verbose_ratio: 0
    init/servo_auto_search: {{min_id: 1, max_id: 3, retry_times: {retries}}}
    init/expected_servo_num: 1
    joint_state: {{use: true, names: [right_shoulder], ids: [1]}}
    diagnostics: {{period_sec: 0.3}}
"""


class Listener:
    """The test's own rclpy node: collects per-namespace messages in a spinning thread."""

    def __init__(self) -> None:
        rclpy.init()
        self.node = Node("multi_bus_test")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.got: dict[str, list] = {}
        self.lock = threading.Lock()
        for ns in ("left", "right"):
            for name, typ in (("dynamixel/debug", DynamixelDebug), ("joint_states", JointState)):
                key = f"/{ns}/{name}"
                self.got[key] = []
                self.node.create_subscription(typ, key, self.got[key].append, 20)
        self.got["/diagnostics"] = []
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.got["/diagnostics"].append, 50)
        self.running = True
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.running:
            with self.lock:
                self.executor.spin_once(timeout_sec=0.02)

    def wait(self, predicate, what: str, timeout: float = 20.0, procs=()) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return
            time.sleep(0.02)
        raise AssertionError(f"timed out waiting for {what}\n" + "\n".join(p.output[-3000:] for p in procs))

    def close(self) -> None:
        self.running = False
        self.thread.join(2)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()


def _present(msg: DynamixelDebug, dxl_id: int) -> float:
    return msg.position_deg.present[list(msg.status.id_list).index(dxl_id)]


def test_two_namespaced_handlers_on_two_buses_do_not_interfere(tmp_path):
    left_bus, right_bus = VirtualBus(servos={1: X, 2: X}), VirtualBus(servos={1: X})
    robot = tmp_path / "robot.yaml"
    robot.write_text(ROBOT_YAML.format(left=left_bus.start(), right=right_bus.start(), retries=SCAN_RETRIES))
    procs = {ns: NodeProcess(node_command() + ["--params-file", str(robot), "-r", f"__ns:=/{ns}"])
             for ns in ("left", "right")}
    ros = Listener()
    try:
        for ns, n in (("left", 2), ("right", 1)):
            ros.wait(lambda: ros.got[f"/{ns}/dynamixel/debug"]
                     and len(ros.got[f"/{ns}/dynamixel/debug"][-1].status.id_list) == n,
                     f"/{ns}/dynamixel/debug with {n} servo(s)", procs=procs.values())
        # each handler found its own bus and uses its own joint names
        ros.wait(lambda: ros.got["/left/joint_states"] and ros.got["/right/joint_states"], "both joint_states")
        assert list(ros.got["/left/joint_states"][-1].name) == ["left_shoulder", "left_elbow"]
        assert list(ros.got["/right/joint_states"][-1].name) == ["right_shoulder"]

        # a command to the left ID 1 moves the left bus's servo 1 only
        right_before = right_bus.servo(1).read("goal_position")
        with ros.lock:
            pub = ros.node.create_publisher(DynamixelControlXPosition, "/left/dynamixel/command/x/position_control", 10)
        ros.wait(lambda: pub.get_subscription_count() > 0, "the left handler subscribed")
        pub.publish(DynamixelControlXPosition(id_list=[1], position_deg=[60.0]))
        ros.wait(lambda: abs(_present(ros.got["/left/dynamixel/debug"][-1], 1) - 60.0) < 1.0,
                 "left ID 1 at 60 deg", procs=procs.values())
        assert right_bus.servo(1).read("goal_position") == right_before
        assert abs(_present(ros.got["/right/dynamixel/debug"][-1], 1) - 60.0) > 10.0

        # a service of the right handler acts on the right bus only
        with ros.lock:
            client = ros.node.create_client(SetTorque, "/right/dynamixel/set_torque")
        assert client.wait_for_service(timeout_sec=10)
        future = client.call_async(SetTorque.Request(ids=[1], enable=False))
        ros.wait(future.done, "the right set_torque answer")
        assert future.result().success, future.result().message
        assert right_bus.servo(1).read("torque_enable") == 0
        assert left_bus.servo(1).read("torque_enable") == 1

        # /diagnostics is shared; the status names say which handler speaks
        def names() -> set[str]:
            return {s.name for msg in list(ros.got["/diagnostics"]) for s in msg.status}
        ros.wait(lambda: {"left/dynamixel_handler: ID 2 (XM430-W350)", "right/dynamixel_handler: ID 1 (XM430-W350)"}
                 <= names(), "diagnostics of both handlers")
        assert "right/dynamixel_handler: ID 2 (XM430-W350)" not in names()

        # a servo going silent on the left bus leaves the right handler's servo answering
        left_bus.set_silent(1, True)
        ros.wait(lambda: not ros.got["/left/dynamixel/debug"][-1].status.ping[0], "left ID 1 ping false")
        n = len(ros.got["/right/dynamixel/debug"])
        ros.wait(lambda: len(ros.got["/right/dynamixel/debug"]) > n + 3, "more right states")
        assert all(ros.got["/right/dynamixel/debug"][-1].status.ping)
    finally:
        codes = {ns: p.stop() for ns, p in procs.items()}
        ros.close()
        left_bus.stop()
        right_bus.stop()
    assert codes == {"left": 0, "right": 0}, "\n".join(p.output for p in procs.values())
