"""Shutdown safety and survival: SIGTERM, SIGKILL (bus watchdog), a vanished device, dummy servos."""
from __future__ import annotations

import signal
import time

from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelControlXVelocity, DynamixelShortcut

from support.rig import X540, Rig, X


def _velocity(rig: Rig, dxl_id: int, deg_s: float) -> None:
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[dxl_id], velocity_deg_s=[deg_s]))
    rig.wait(lambda: abs(rig.debug_of(dxl_id)["velocity"] - deg_s) < 5, timeout=15, what=f"ID {dxl_id} turning")


def test_sigterm_stops_velocity_servos_and_disables_torque():
    rig = Rig({1: X, 2: X540}, "mode_change_interval_sec:=0.0")
    try:
        _velocity(rig, 1, 60.0)
        assert rig.sim.servo(1).read("goal_velocity") != 0
    finally:
        code = rig.node_proc.stop(signal.SIGTERM)
        rig.close()
    assert code == 0
    assert "stopping (term/servo_auto_stop, term/torque_auto_disable)" in rig.node_proc.output
    for i in (1, 2):
        assert rig.sim.servo(i).read("torque_enable") == 0
    assert rig.sim.servo(1).read("goal_velocity") == 0


def test_sigkill_leaves_a_velocity_servo_stopped_by_the_bus_watchdog():
    # 500 ms: a loaded host can hold a 100 Hz loop back for 100 ms, and a watchdog that trips while
    # the node runs is cleared and armed again by the node (tested below), which this test is not about
    rig = Rig({1: X}, "default/bus_watchdog:=500.0", "term/torque_auto_disable:=false")
    try:
        servo = rig.sim.servo(1)
        assert servo.read("bus_watchdog") == 0  # position mode: no watchdog
        _velocity(rig, 1, 90.0)
        rig.wait(lambda: servo.read("bus_watchdog") == 25, what="the watchdog armed: 500 ms / 20 ms")
        rig.node_proc.proc.send_signal(signal.SIGKILL)
        rig.node_proc.proc.wait(10)
        assert servo.read("torque_enable") == 1  # nobody switched it off...
        rig.wait(lambda: servo.read("bus_watchdog") == -1, timeout=5, what="the watchdog tripped, as the e-Manual says")
        rig.wait(lambda: servo.read("present_velocity") == 0, timeout=5, what="...it stopped by itself")
        assert servo.read("torque_enable") == 1
    finally:
        rig.close()


def test_device_vanishing_is_reported_survived_and_reconnected(tmp_path):
    link = str(tmp_path / "ttyDXL")
    rig = Rig({1: X, 2: X540}, "pub_ratio/status:=5", sim_kwargs={"link": link})
    try:
        rig.sim.vanish()
        rig.node_proc.wait_for("is gone (the port hung up", timeout=10)
        rig.wait(lambda: not any(rig.debug[-1].status.ping), what="ping false while the device is gone")
        n = len(rig.debug)
        rig.wait(lambda: len(rig.debug) > n + 5, what="states still published without the device")
        rig.sim.reappear()
        rig.node_proc.wait_for("is back: reconnected", timeout=10)
        rig.wait(lambda: all(rig.debug[-1].status.ping), what="ping true again")
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[2], position_deg=[30.0]))
        rig.wait(lambda: abs(rig.debug_of(2)["position"] - 30.0) < 0.5, timeout=15, what="commands work after reconnect")
    finally:
        assert rig.close() == 0


def test_a_servo_silent_past_its_watchdog_takes_commands_as_soon_as_it_answers_again():
    """While a servo does not hear the bus its watchdog trips, and a tripped servo refuses goals. When
    it answers again the handler clears and re-arms the watchdog before the next commands, instead
    of waiting for the next periodic watchdog check (here: never, extra dynamic items read once)."""
    rig = Rig({1: X, 2: X540}, "default/bus_watchdog:=100.0", "pub_ratio/extra.dynamic_items:=0",
              "pub_ratio/status:=5")
    try:
        _velocity(rig, 2, 30.0)  # velocity mode: the watchdog is armed
        rig.wait(lambda: rig.sim.servo(2).read("bus_watchdog") == 5, what="ID 2's watchdog armed")
        rig.sim.set_silent(2)
        rig.wait(lambda: not rig.debug_of(2)["ping"], what="ID 2 ping false")
        # a watchdog period without an instruction trips it
        rig.wait(lambda: rig.sim.servo(2).read("bus_watchdog") == -1, timeout=5, what="ID 2's watchdog tripped")
        rig.sim.set_silent(2, False)
        rig.wait(lambda: rig.debug_of(2)["ping"], what="ID 2 answering again")
        rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[2], velocity_deg_s=[-20.0]))
        rig.wait(lambda: rig.sim.servo(2).read("goal_velocity") == round(-20.0 / 1.374), timeout=5,
                 what="the goal accepted by the servo that came back")
        rig.wait(lambda: rig.sim.servo(2).read("bus_watchdog") == 5, what="ID 2's watchdog armed again")
    finally:
        assert rig.close() == 0


def test_dummy_servos_mix_with_real_ones_and_follow_commands():
    # ID 2 exists on the bus too: the dummy wins and the real servo is never addressed
    rig = Rig({1: X, 2: X540}, "init/dummy_servo_list:=[2, 7, 300]", "init/servo_auto_search.max_id:=3",
              expect=3)
    try:
        ids = list(rig.debug[-1].status.id_list)
        assert ids == [1, 2, 7]
        rig.node_proc.wait_for("IDs [300] are outside 0..252: ignored")
        rig.node_proc.wait_for("ID 7: XM430-W350 (dummy, series X) handled")
        before = rig.sim.servo(2).read("goal_position")
        rig.sim.clear_log()
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1, 2, 7], position_deg=[20.0, -20.0, 45.0]))
        rig.wait(lambda: all(abs(rig.debug_of(i)["position"] - g) < 0.5 for i, g in ((1, 20.0), (2, -20.0), (7, 45.0))),
                 timeout=15, what="real and dummy servos at their goals")
        assert rig.sim.servo(2).read("goal_position") == before  # the real ID 2 never got the command
        assert all(2 not in entry.ids for entry in rig.sim.log if entry.ids)
    finally:
        assert rig.close() == 0


def test_dummy_only_node_without_a_device_publishes_complete_states_and_follows_commands():
    import rclpy
    from rclpy.node import Node

    from dynamixel_handler_msgs.msg import DxlStates

    from support.ros import NodeProcess, node_command

    proc = NodeProcess(node_command("device_name:=/dev/ttyDOES_NOT_EXIST", "init/dummy_servo_list:=[3, 4]",
                                    "pub_ratio/status:=3", "pub_ratio/goal:=3", "pub_ratio/limit:=3", "pub_ratio/gain:=3",
                                    "pub_ratio/error:=3", "pub_ratio/extra.dynamic_items:=3", "pub_ratio/extra.static_items:=3",
                                    "pub_ratio/present.input_voltage:=3", "pub_ratio/present.temperature:=3"))
    rclpy.init()
    node = Node("test_dummy_only")
    full: list[DxlStates] = []
    node.create_subscription(DxlStates, "/dynamixel/states",
                             lambda m: full.append(m) if len(m.limit.id_list) == 2 else None, 10)
    pub = node.create_publisher(DynamixelControlXPosition, "/dynamixel/command/x/position_control", 10)
    try:
        proc.wait_for("dummy servos only: running without the device", timeout=30)
        end = time.monotonic() + 20
        while not full and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        assert full, proc.output
        m = full[-1]
        for group in (m.status, m.present, m.goal, m.gain, m.limit, m.error, m.extra):
            assert list(group.id_list) == [3, 4]
        assert list(m.extra.model) == ["X", "X"]
        assert all(len(getattr(m.present, f)) == 2 for f in ("position_deg", "velocity_deg_s", "current_ma"))
        assert m.limit.max_position_limit_deg[0] > 0 and m.present.input_voltage_v[0] > 0
        pub.publish(DynamixelControlXPosition(id_list=[3, 4], position_deg=[-30.0, 60.0]))
        end = time.monotonic() + 20
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
            if full and [round(v) for v in full[-1].present.position_deg] == [-30, 60]:
                break
        else:
            raise AssertionError(f"dummies did not follow: {list(full[-1].present.position_deg)}\n{proc.output}")
    finally:
        node.destroy_node()
        rclpy.shutdown()
        assert proc.stop() == 0


def test_baudrate_auto_set_moves_servos_at_other_rates_before_the_scan():
    rig = Rig({1: X, 2: X540}, "init/baudrate_auto_set:=true", "baudrate:=1000000",
              sim_kwargs={"check_baudrate": True}, before_start=lambda sim: sim.servo(2).write("baud_rate", 1))
    try:
        assert rig.sim.servo(2).read("baud_rate") == 3  # 57600 -> 1 Mbps
        assert list(rig.debug[-1].status.id_list) == [1, 2]
        rig.node_proc.wait_for("baudrate auto set")
        # every line of the search says what it belongs to, as docs/parameters.md promises
        lines = rig.node_proc.output.splitlines()
        first = next(k for k, line in enumerate(lines) if "baudrate auto set" in line)
        scan = next(k for k, line in enumerate(lines) if "scan 1/" in line)
        search = [line for line in lines[first:scan] if line.startswith(("[INFO]", "[WARN]"))]
        assert len(search) >= 5 and all("]: baudrate auto set: " in line for line in search), "\n".join(search)
        assert any("at 57600 bps: ID 1 (XM430-W350), ID 2" in line for line in search), "\n".join(search)
    finally:
        assert rig.close() == 0


def test_reboot_and_add_id_keep_the_watchdog_and_profiles_the_handler_set():
    # a 16 ms adapter: on a busy host a late reply is not one of the 3 silences that remove a servo
    rig = Rig({1: X, 2: X540}, "clear_error_interval_sec:=0.0", "no_response_id_auto_remove_count:=3",
              "mode_change_interval_sec:=0.0", "latency_timer:=16")
    try:
        _velocity(rig, 1, 10.0)  # velocity mode: the bus watchdog is armed
        _velocity(rig, 2, 10.0)
        servo = rig.sim.servo(1)
        before = {k: servo.read(k) for k in ("bus_watchdog", "profile_velocity", "profile_acceleration")}
        assert before["bus_watchdog"] > 0 and before["profile_velocity"] > 0
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="reboot", id_list=[1]))
        rig.wait(lambda: rig.sim.log and any(e.name == "reboot" for e in rig.sim.log), what="the reboot on the wire")
        rig.wait(lambda: {k: servo.read(k) for k in before} == before, what="RAM settings restored after the reboot")
        # a servo removed (silent) and added again is set up like the others
        rig.sim.set_silent(2, True)
        rig.node_proc.wait_for("ID 2: no response 3 times in a row: removed")
        rig.sim.servo(2).write("bus_watchdog", 0)
        rig.sim.set_silent(2, False)
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="ADID", id_list=[2]))
        rig.wait(lambda: rig.sim.servo(2).read("bus_watchdog") == before["bus_watchdog"], what="watchdog armed on the added servo")
    finally:
        assert rig.close() == 0


def test_an_exception_in_the_loop_is_logged_and_the_loop_goes_on(monkeypatch):
    monkeypatch.setenv("DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS", "3")
    rig = Rig({1: X})
    try:
        n = len(rig.debug)
        rig.wait(lambda: len(rig.debug) > n + 20, what="the loop publishing after the faults")
    finally:
        assert rig.close() == 0
    out = rig.node_proc.output
    assert out.count(": RuntimeError: fault injected by DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS") == 3
    assert "]: loop 0: RuntimeError" in out and "(at node.py:" in out  # logged with where it was raised


def test_a_loop_that_keeps_failing_stops_the_servos_and_exits_non_zero(monkeypatch):
    from dynamixel_handler.sim import VirtualBus

    from support.ros import PATIENT_SCAN, NodeProcess, node_command

    monkeypatch.setenv("DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS", "1000")
    with VirtualBus(servos={1: X}) as sim:
        # the scan repeated until the servo answers: with a 1 ms adapter's wait, one scan on a loaded
        # machine found nobody and the node exited (1) before its loop ever ran
        proc = NodeProcess(node_command(f"device_name:={sim.path}", "latency_timer:=1", "init/servo_auto_search.max_id:=1",
                                        "init/expected_servo_num:=1", PATIENT_SCAN))
        assert proc.wait_exit(30) == 1
        assert "the loop failed 50 times in a row: shutting down safely" in proc.output
        assert sim.servo(1).read("torque_enable") == 0
