"""The ``servos`` block of the parameters file through the real node on the virtual bus: applied at
start-up and read back, put back after a mode change and a reboot, no EEPROM write on a second
start, each refusal one line and exit code 2, the entries described, and the snapshot service.

XM430-W350 (e-Manual): velocity 0.229 rpm a unit (1.374 deg/s), position P gain 800 at the
factory and again after every mode change, Operating Mode 3 position / 5 current-based position.
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import yaml
from rcl_interfaces.srv import DescribeParameters
from std_srvs.srv import Trigger

from dynamixel_handler.protocol import REBOOT, WRITE
from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelGain, DynamixelShortcut, DynamixelStatus

from support.rig import Rig, scan_params
from support.ros import PATIENT_SCAN, NodeProcess, node_command

XM430, PH54 = 1020, 2020
DEG_S = 0.229 * 6.0  # deg/s per velocity unit
EEPROM_END = 64      # X series: the EEPROM area is addresses 0..63

BLOCK = """\
joint_state: {names: [base, wrist], ids: [1, 2]}
servos:
  id_1: {mode: cur_position, position_p_gain_pulse: 640, velocity_limit_deg_s: 120.0, profile_vel_deg_s: 60.0,
         return_delay_time_us: 20.0}
  wrist: {position_p_gain_pulse: 700, drive_mode: {reverse_mode: true}, shutdown: {overload_error: false},
          force: true}
"""


def params_file(tmp_path: Path, body: str, name: str = "servos.yaml") -> Path:
    path = tmp_path / name
    path.write_text("/**:\n  ros__parameters:\n" + textwrap.indent(textwrap.dedent(body), "    "))
    return path


def start(rig: Rig, path: Path, *params: str) -> None:
    """The node on the rig's bus with the shipped parameters, then ``path`` (as Rig.start_node)."""
    cmd = node_command(f"device_name:={rig.device}", *scan_params(rig.servo_ids, len(rig.servo_ids)),
                       "mode_change_interval_sec:=0.0", "clear_error_interval_sec:=0.0", *params)
    rig.node_proc = NodeProcess(cmd + ["--params-file", str(path)])
    rig.node_proc.wait_for("loop running", timeout=30)
    rig.wait(lambda: (m := rig.debug.last()) is not None and len(m.status.id_list) == len(rig.servo_ids),
             timeout=30, what="the first /dynamixel/debug")


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).registers.peek(item)


AT_START = ("operating_mode", "position_p_gain", "velocity_limit", "profile_velocity", "return_delay_time",
            "drive_mode", "shutdown")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    r = Rig({1: XM430, 2: XM430}, start_node=False)
    folder = tmp_path_factory.mktemp("servos")
    r.snapshot = f"servos_snapshot.path:={folder / 'saved.yaml'}"  # each start of the node's
    start(r, params_file(folder, BLOCK), r.snapshot)
    # the registers as the start-up left them, before any test's command changes them (any order)
    r.at_start = {(i, item): reg(r, i, item) for i in (1, 2) for item in AT_START}
    r.torque_at_start = {i: (r.debug_of(i)["torque"], r.debug_of(i)["goal_position"], r.debug_of(i)["position"])
                         for i in (1, 2)}
    r.lines_at_start = {i: r.wait_log(f"ID {i} (XM430-W350): servos.") for i in (1, 2)}
    r.output_at_start = r.output
    yield r
    assert r.close() == 0


def test_the_block_is_applied_at_start_up_read_back_and_said_in_one_line_per_servo(rig):
    def at_start(dxl_id: int, item: str) -> int:
        return rig.at_start[(dxl_id, item)]
    assert at_start(1, "operating_mode") == 5
    assert at_start(1, "position_p_gain") == 640
    assert at_start(1, "velocity_limit") == round(120.0 / DEG_S)
    assert at_start(1, "profile_velocity") == round(60.0 / DEG_S)
    assert at_start(1, "return_delay_time") == 10
    assert at_start(2, "position_p_gain") == 700  # named by its joint
    assert at_start(2, "drive_mode") & 1 == 1
    assert at_start(2, "shutdown") & 0x20 == 0
    assert at_start(2, "profile_velocity") == round(1000.0 / DEG_S)  # not in the block: the default
    line = rig.lines_at_start[1]
    assert "servos.id_1 set:" in line
    assert "mode cur_position" in line and "position_p_gain_pulse 640" in line and line.endswith("read back")
    assert "velocity_limit_deg_s 120.0 (EEPROM, written)" in line
    assert "servos.wrist set:" in rig.lines_at_start[2]
    for dxl_id in (1, 2):  # torque on, nothing moved
        torque, goal, position = rig.torque_at_start[dxl_id]
        assert torque and abs(goal - position) < 1.0
    assert "Traceback" not in rig.output_at_start and "unknown parameter" not in rig.output_at_start


def test_the_gains_come_back_after_a_mode_change(rig):
    mode = "position" if reg(rig, 1, "operating_mode") != 3 else "cur_position"  # a change, whatever ran before
    mark = rig.mark()
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], mode=[mode]))
    rig.wait_log(f"servos.id_1 put back after the mode change to {mode}", since=mark)
    # the command's mode holds until the next set-up
    assert reg(rig, 1, "operating_mode") == {"position": 3, "cur_position": 5}[mode]
    assert reg(rig, 1, "position_p_gain") == 640 and reg(rig, 1, "profile_velocity") == round(60.0 / DEG_S)


def test_a_gain_command_wins_until_a_reboot_puts_the_file_value_back(rig):
    rig.publish("/dynamixel/command/gain", DynamixelGain(id_list=[1], position_p_gain_pulse=[900]))
    rig.wait(lambda: reg(rig, 1, "position_p_gain") == 900, what="the commanded gain")
    mark = rig.mark()
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="reboot", id_list=[1]))
    rig.wait_log("servos.id_1 put back after a reboot", since=mark)
    assert any(e.instruction == REBOOT for e in rig.sim.log)
    assert reg(rig, 1, "position_p_gain") == 640


def test_the_entries_are_described_as_parameters(rig):
    client = rig.node.create_client(DescribeParameters, "/dynamixel_handler/describe_parameters")
    assert client.wait_for_service(timeout_sec=10)
    future = client.call_async(DescribeParameters.Request(names=["servos.id_1.position_p_gain_pulse",
                                                                 "servos.wrist.drive_mode.reverse_mode"]))
    rig.wait(future.done, what="describe_parameters")
    gain, reverse = future.result().descriptors
    assert "position p gain [pulse]" in gain.description and "ID 1" in gain.description and gain.read_only
    assert "reverse" in reverse.description and "ID 2" in reverse.description


def test_the_snapshot_service_writes_a_block_that_loads_back(rig, tmp_path):
    rig.publish("/dynamixel/command/gain", DynamixelGain(id_list=[2], position_d_gain_pulse=[120]))
    rig.wait(lambda: reg(rig, 2, "position_d_gain") == 120, what="the commanded gain")
    client = rig.node.create_client(Trigger, "/dynamixel/save_servo_settings")
    assert client.wait_for_service(timeout_sec=10)
    future = client.call_async(Trigger.Request())
    rig.wait(future.done, timeout=15, what="save_servo_settings")
    answer = future.result()
    assert answer.success, answer.message
    path = Path(answer.message.rsplit(" written to ", 1)[1])
    assert path.name == "saved.yaml" and answer.message.startswith("servos block of IDs [1, 2] written to ")
    block = yaml.safe_load(path.read_text())["/**"]["ros__parameters"]["servos"]
    assert block["id_2"]["position_d_gain_pulse"] == 120 and block["id_2"]["drive_mode"]["reverse_mode"] is True
    assert block["id_1"]["position_p_gain_pulse"] == 640 and block["id_1"]["velocity_limit_deg_s"] == pytest.approx(
        round(120.0 / DEG_S) * DEG_S, abs=1e-3)


def eeprom_writes(rig: Rig) -> list[tuple]:
    return [(e.ids, e.address, e.params) for e in rig.sim.log if e.instruction == WRITE and e.address is not None
            and e.address < EEPROM_END]


def test_a_restart_writes_only_what_differs_from_the_file_and_then_no_eeprom(rig, tmp_path):
    assert rig.stop_node() == 0
    rig.sim.servo(1).registers.poke("operating_mode", 3)  # as a mode command leaves it: the file's comes back
    rig.sim.clear_log()
    start(rig, params_file(tmp_path, BLOCK), rig.snapshot)
    line = rig.wait_log("ID 1 (XM430-W350): servos.id_1 set:")
    assert "velocity_limit_deg_s 120.0 (EEPROM, already so)" in line and "mode cur_position," in line
    assert eeprom_writes(rig) == [((1,), 11, b"\x0b\x00\x05")]  # Operating Mode := 5, nothing else
    assert reg(rig, 1, "operating_mode") == 5
    assert rig.stop_node() == 0
    rig.sim.clear_log()
    start(rig, params_file(tmp_path, BLOCK), rig.snapshot)
    line = rig.wait_log("ID 1 (XM430-W350): servos.id_1 set:")
    assert eeprom_writes(rig) == []
    assert "mode cur_position (already so)" in line


# ---------------------------------------------------------------------------------------- refusals
REFUSED = [
    ("id_1: {position_p_gain: 640}", "servos.id_1.position_p_gain = 640: unknown item: did you mean "
                                     "'position_p_gain_pulse'?"),
    ("id_1: {position_p_gain_pulse: fast}", "servos.id_1.position_p_gain_pulse = 'fast': must be int"),
    ("elbow: {position_p_gain_pulse: 640}", "servos.elbow: neither id_<N> nor a joint name"),
    ("id_1: {velocity_limit_deg_s: 5000.0}", "servos.id_1.velocity_limit_deg_s = 5000.0: ID 1 (XM430-W350) is "
                                             "outside its e-Manual range 0..1405"),
    ("id_2: {mode: cur_position}", "servos.id_2.mode = cur_position: ID 2 (PH54-200-S500-R) has no 'cur_position' mode"),
    ("id_1: {led: {green_percent: 100.0}}", "servos.id_1.led.green_percent = 100.0: ID 1 (XM430-W350) has no led"),
    ("id_5: {position_p_gain_pulse: 640}", "servos.id_5: ID 5 is not on the bus"),
]


@pytest.fixture(scope="module")
def bus():
    r = Rig({1: XM430, 2: PH54}, start_node=False)
    yield r
    r.close()


@pytest.mark.parametrize("entry, line", REFUSED, ids=[r[1].split(":")[0] + str(k) for k, r in enumerate(REFUSED)])
def test_each_refusal_is_one_line_and_exit_code_2_with_nothing_written(bus, tmp_path, entry, line):
    bus.sim.clear_log()
    path = params_file(tmp_path, "servos:\n  " + entry + "\n")
    node = NodeProcess(node_command(f"device_name:={bus.device}", *scan_params([1, 2], 2)) + ["--params-file", str(path)])
    assert node.wait_exit(30) == 2, node.output
    fatal = [x for x in node.output.splitlines() if "bad parameter" in x]
    assert len(fatal) == 1 and line in fatal[0], node.output
    assert "Traceback" not in node.output
    assert not [e for e in bus.sim.log if e.instruction == WRITE]


def test_several_refusals_are_a_line_each(bus, tmp_path):
    path = params_file(tmp_path, "servos:\n  id_1: {velocity_limit_deg_s: 5000.0, led: {green_percent: 100.0}}\n")
    node = NodeProcess(node_command(f"device_name:={bus.device}", *scan_params([1, 2], 2)) + ["--params-file", str(path)])
    assert node.wait_exit(30) == 2, node.output
    assert "velocity_limit_deg_s = 5000.0" in node.output and "led.green_percent = 100.0" in node.output
    assert "the servos block has 2 refused items" in node.output


def test_a_command_line_entry_is_applied_as_one_from_a_file(tmp_path):
    r = Rig({1: XM430}, "servos.id_1.position_p_gain_pulse:=640", "servos.id_1.profile_acc_deg_ss:=1000")
    try:
        assert reg(r, 1, "position_p_gain") == 640
        assert "servos.id_1 set: position_p_gain_pulse 640, profile_acc_deg_ss 1000.0" in r.wait_log("servos.id_1 set")
    finally:
        assert r.close() == 0


def test_a_slow_profile_is_the_smallest_step_never_no_limit_from_the_block_and_from_a_command():
    """Profile Velocity and Acceleration 0 are "no limit" to the firmware: 0.5 deg/s and 10 deg/s^2,
    less than one step each (1.374 deg/s, 21.5 deg/s^2), are written as one step, and said so."""
    r = Rig({1: XM430}, "servos.id_1.profile_vel_deg_s:=0.5", "servos.id_1.profile_acc_deg_ss:=10.0")
    try:
        assert reg(r, 1, "profile_velocity") == 1 and reg(r, 1, "profile_acceleration") == 1
        line = r.wait_log("servos.id_1 set")
        assert "profile_vel_deg_s 0.5 (less than one step: written as 1.374, not as 0, which the servo takes " \
               "for no limit)" in line, line
        mark = r.mark()
        r.publish("/dynamixel/command/x/position_control",
                  DynamixelControlXPosition(id_list=[1], position_deg=[90.0], profile_vel_deg_s=[0.3]))
        r.wait(lambda: reg(r, 1, "goal_position") == 2048 + 1024, what="the goal written")
        assert reg(r, 1, "profile_velocity") == 1
        r.wait_log("ID 1 (XM430-W350) 'profile_vel_deg_s' = 0.3 is less than one step of profile_velocity (1.374): "
                   "written as 1.374", since=mark)
        # on its way at the slowest profile, not at full speed
        r.wait(lambda: r.debug_of(1)["position"] > 0.5, what="ID 1 moving")
        assert r.debug_of(1)["velocity"] == pytest.approx(DEG_S, abs=0.01)
    finally:
        assert r.close() == 0


def test_the_block_comes_back_after_a_reconnect_and_for_a_servo_added_again(tmp_path):
    r = Rig({1: XM430}, sim_kwargs={"link": str(tmp_path / "ttyDXL")}, start_node=False)
    try:
        start(r, params_file(tmp_path, "servos:\n  id_1: {position_p_gain_pulse: 640, profile_vel_deg_s: 60.0}\n"))
        servo = r.sim.servo(1)
        assert servo.read("position_p_gain") == 640
        mark = r.mark()
        r.sim.vanish()
        r.node_proc.wait_for("is gone (the port hung up", timeout=10)
        servo.write("position_p_gain", 800)  # the servo lost power with the adapter: RAM at its defaults
        servo.write("profile_velocity", 0)
        r.sim.reappear()
        r.wait_log("ID 1 (XM430-W350): servos.id_1 set:", since=mark, timeout=15)
        assert servo.read("position_p_gain") == 640 and servo.read("profile_velocity") == round(60.0 / DEG_S)
        r.publish("/dynamixel/shortcut", DynamixelShortcut(command="remove_id", id_list=[1]))
        r.wait_log("ID 1: removed from the handled servos", since=mark)
        servo.write("position_p_gain", 800)
        mark = r.mark()
        r.publish("/dynamixel/shortcut", DynamixelShortcut(command="add_id", id_list=[1]))
        r.wait_log("ID 1 (XM430-W350): servos.id_1 set:", since=mark)
        assert servo.read("position_p_gain") == 640
    finally:
        assert r.close() == 0


def test_a_launch_file_given_a_file_with_the_block_applies_it(tmp_path):
    from support.launch_runner import nodes
    r = Rig({1: XM430}, start_node=False)
    try:
        path = params_file(tmp_path, "servos:\n  id_1: {position_p_gain_pulse: 640, drive_mode: {reverse_mode: true}, force: true}\n")
        (spec,) = nodes("dynamixel_handler_launch.py", device_name=r.device, params_file=str(path))
        r.node_proc = NodeProcess(spec.command(tmp_path) + ["-p", PATIENT_SCAN])
        r.wait_log("servos.id_1 set: drive_mode.reverse_mode True (EEPROM, written), position_p_gain_pulse 640",
                   timeout=30)
        assert reg(r, 1, "position_p_gain") == 640 and reg(r, 1, "drive_mode") & 1
    finally:
        assert r.close() == 0
