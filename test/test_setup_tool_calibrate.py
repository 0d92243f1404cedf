"""dynamixel_handler_setup calibrate as a process against the virtual bus (served from this
process, so that the test turns the shafts as a hand would: between the tool's reads the virtual
servo's motor is moved, no instruction on the bus), the Enter lines fed through stdin, every
register read back with dynamixel_sdk: the file's offsets and limits match the angles the shafts
were moved to, the node's parser takes it, torque is left off; the node started with the file
publishes the joint at 0 at the zero pose and holds a command to its limits; a Protocol 1.0 servo too;
``--homing-offset`` writes each servo's Homing Offset so that it reads 0 at the zero pose (and
nothing when not confirmed); refusals (torque on without ``--torque-off``, an existing file, a range
smaller than the margins, an unknown ID, SIGINT / SIGTERM, ``--homing-offset`` on a Protocol 1.0
servo or a model without one) write nothing and say so in one line."""
from __future__ import annotations

import math
import signal
import sys
import time
from pathlib import Path
from typing import Iterator

import pytest
import yaml
from sensor_msgs.msg import JointState
from test_setup_tool import TOOL, Lines
from test_setup_tool_safety import PRESENT_POS, TORQUE, hold, sdk_read

from dynamixel_handler.joints.block import joints_block
from dynamixel_handler.sim import VirtualBus

from support.rig import Rig, scan_params
from support.ros import NodeProcess, node_command

XM430, XM540, AX12, XL320 = 1020, 1120, 12, 350
DEG_PER_PULSE = 360.0 / 4096  # X series: 0 deg at 2048 (ROBOTIS e-Manual)
TWO_PULSES_RAD = math.radians(2 * DEG_PER_PULSE)
HOMING_ADDR, READ = 20, 0x02
RECORD, ZERO = "then press Enter", "hold the robot at its zero pose"


@pytest.fixture
def bus() -> Iterator[VirtualBus]:
    with VirtualBus([(1, XM430), (2, XM540), (7, AX12), (8, XL320)], wire_timing=False) as sim:
        yield sim


def _reads(sim: VirtualBus, dxl_id: int, since: float) -> int:
    """Reads of the servo's Present Position since ``since`` (a Protocol 1.0 servo: its instructions,
    which the bus counts but does not log)."""
    if dxl_id == 7:
        return sim.stats["protocol1_instructions"]
    return len([e for e in list(sim.log) if e.time > since and e.instruction == READ and e.ids == (dxl_id,)
                and e.address == PRESENT_POS])


def set_angle(sim: VirtualBus, dxl_id: int, deg: float) -> None:
    """Turn a shaft (torque off) to ``deg`` as a hand would (no instruction on the bus), then wait
    until the tool has read the servo's position twice since, so that its table has seen the angle."""
    since = time.monotonic()
    before = _reads(sim, dxl_id, since)
    sim.turn(dxl_id, deg)
    end = time.monotonic() + 20
    while time.monotonic() < end:
        if _reads(sim, dxl_id, since) >= before + 2:
            return
        time.sleep(0.01)
    raise AssertionError(f"the tool did not read ID {dxl_id}'s position after it was turned")


def calibrate(sim: VirtualBus, *args: str, bps: int = 57600) -> Lines:
    cmd = [TOOL] if TOOL else [sys.executable, "-m", "dynamixel_handler.setup_tool"]
    return Lines([*cmd, "calibrate", *args, "--device", sim.path, "--baud", str(bps), "--latency", "100",
                  "--rate", "20"])


def by_hand(run: Lines, sim: VirtualBus, moves: list[tuple[int, float]], zero: list[tuple[int, float]]) -> None:
    """As an owner would: each joint moved through its range (``moves``: ID, angle in turn), Enter,
    the robot held at its zero pose (``zero``), Enter."""
    run.wait_for(RECORD)
    for dxl_id, deg in moves:
        set_angle(sim, dxl_id, deg)
    run.send("")
    run.wait_for(ZERO)
    for dxl_id, deg in zero:
        set_angle(sim, dxl_id, deg)
    run.send("")


def finished(run: Lines, timeout: float = 30.0) -> int:
    code = run.proc.wait(timeout)
    run._reader.join(5)
    assert not any("Traceback" in line for line in run.lines), "\n".join(run.lines)
    return code


def error_line(run: Lines) -> str:
    errors = [line for line in run.lines if line.startswith("error: ")]
    assert len(errors) == 1, "\n".join(run.lines)
    return errors[0]


def flat(tree: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in tree.items():
        out.update(flat(value, f"{prefix}{key}.") if isinstance(value, dict) else {f"{prefix}{key}": value})
    return out


def parsed(path: Path) -> dict:
    """The file as the node's own parser takes it: joint name -> Joint."""
    joints, mimics = joints_block(flat(yaml.safe_load(path.read_text())["/**"]["ros__parameters"]))
    assert not mimics
    return joints


# ---------------------------------------------------------------------------- a calibration
def test_the_joints_moved_by_hand_give_offsets_and_limits_the_node_takes(bus, tmp_path):
    hold(bus, 2)  # ID 2 holds its load: its torque goes off only with --torque-off
    target = tmp_path / "joints.yaml"
    run = calibrate(bus, "2,1", "--joints", str(target), "--names", "elbow,shoulder", "--torque-off", "--yes")
    try:
        by_hand(run, bus, [(1, -60.0), (2, 40.0), (1, 75.0), (2, -100.0), (1, 12.0)], [(1, -30.0), (2, 10.0)])
        assert finished(run) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    out = "\n".join(run.lines)
    assert "torque off on ID 2, 1 (ID 2 held a load: no longer)" in out and "\x1b[" not in out, out
    assert f"written to {target}" in out and "torque left off on ID 2, 1" in out, out
    joints = parsed(target)
    assert list(joints) == ["elbow", "shoulder"] and (joints["elbow"].dxl_id, joints["shoulder"].dxl_id) == (2, 1)
    # joint = offset + servo angle: 0 at the zero pose; the limits 5 deg inside the range moved through
    for name, zero, low, high in (("shoulder", -30.0, -60.0, 75.0), ("elbow", 10.0, -100.0, 40.0)):
        joint = joints[name]
        assert joint.zero == pytest.approx(-math.radians(zero), abs=TWO_PULSES_RAD), name
        assert joint.position_limits == pytest.approx((math.radians(low - zero + 5), math.radians(high - zero - 5)),
                                                      abs=2 * TWO_PULSES_RAD), name
    for dxl_id in (1, 2):
        assert sdk_read(bus.path, 57600, dxl_id, TORQUE, 1) == 0
        assert sdk_read(bus.path, 57600, dxl_id, HOMING_ADDR, 4) == 0  # nothing written to EEPROM
    assert sorted(p.name for p in tmp_path.iterdir()) == ["joints.yaml"]  # no temporary file left


def test_homing_offset_makes_the_servo_read_0_at_the_zero_pose(bus, tmp_path):
    target = tmp_path / "joints.yaml"
    target.write_text("an older calibration\n")  # replaced, with --force
    run = calibrate(bus, "1", "--joints", str(target), "--homing-offset", "--margin-deg", "2", "--force")
    try:
        by_hand(run, bus, [(1, -50.0), (1, 60.0)], [(1, 20.0)])
        asked = run.wait_for("[y/N]")
        shown = "\n".join(run.lines[:asked])
        assert "Homing Offset (EEPROM)" in shown and "0 deg (raw 0)" in shown and "-20.04 deg (raw -228)" in shown, shown
        run.send("y")
        assert finished(run) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    assert "homing_offset = -20.04 deg (raw -228) (was 0 deg (raw 0)), read back" in "\n".join(run.lines)
    assert sdk_read(bus.path, 57600, 1, HOMING_ADDR, 4) == -228  # 20 deg = 227.6 pulses
    assert abs(sdk_read(bus.path, 57600, 1, PRESENT_POS, 4) - 2048) <= 1  # 0 deg at the zero pose
    assert sdk_read(bus.path, 57600, 1, TORQUE, 1) == 0
    joint = parsed(target)["joint_1"]
    assert joint.zero == 0.0
    assert joint.position_limits == pytest.approx((math.radians(-50 - 20 + 2), math.radians(60 - 20 - 2)),
                                                  abs=2 * TWO_PULSES_RAD)


def test_a_protocol1_servo_is_calibrated_too(bus, tmp_path):
    target = tmp_path / "joints.yaml"
    run = calibrate(bus, "7", "--joints", str(target), "--names", "gripper_arm", bps=1_000_000)
    try:
        by_hand(run, bus, [(7, -100.0), (7, 120.0)], [(7, 10.0)])
        assert finished(run) == 0, "\n".join(run.lines)
    finally:
        run.stop()
    joint = parsed(target)["gripper_arm"]  # AX-12A: 0.29 deg per pulse
    pulse = math.radians(300 / 1023)
    assert joint.zero == pytest.approx(-math.radians(10.0), abs=pulse)
    assert joint.position_limits == pytest.approx((math.radians(-105), math.radians(105)), abs=2 * pulse)


def test_a_homing_offset_not_confirmed_is_not_written_nor_the_file(bus, tmp_path):
    target = tmp_path / "joints.yaml"
    run = calibrate(bus, "1", "--joints", str(target), "--homing-offset")
    try:
        by_hand(run, bus, [(1, -50.0), (1, 60.0)], [])
        run.wait_for("[y/N]")
        run.send("n")
        assert finished(run) == 1
    finally:
        run.stop()
    line = error_line(run)
    assert line.startswith("error: not confirmed: nothing written") and line.endswith(
        f"{target} not written; torque left off on ID 1"), line
    assert sdk_read(bus.path, 57600, 1, HOMING_ADDR, 4) == 0 and not list(tmp_path.iterdir())


def test_the_node_takes_the_file_its_joint_reads_0_at_the_zero_pose_and_is_held_to_its_limits(tmp_path):
    target = tmp_path / "arm.yaml"
    rig = Rig({1: XM430}, start_node=False)
    try:
        run = calibrate(rig.sim, "1", "--joints", str(target), "--names", "shoulder")
        try:
            by_hand(run, rig.sim, [(1, -60.0), (1, 80.0)], [(1, 30.0)])
            assert finished(run) == 0, "\n".join(run.lines)
        finally:
            run.stop()
        rig.node_proc = NodeProcess(node_command(f"device_name:={rig.device}", *scan_params([1], 1))
                                    + ["--params-file", str(target)])
        rig.node_proc.wait_for("handled", timeout=30)
        got: list[JointState] = []
        with rig._lock:
            rig.node.create_subscription(JointState, "/joint_states", got.append, 50)
        rig.wait(lambda: bool(got) and list(got[-1].name) == ["shoulder"] and abs(got[-1].position[0]) < TWO_PULSES_RAD,
                 timeout=15, what="joint_states: the shoulder at 0 rad at the zero pose")
        mark = rig.mark()
        rig.publish("/joint_commands", JointState(name=["shoulder"], position=[3.0]))
        # moved through -60 .. 80 deg of the servo, zero at 30: -90 .. 50 deg of the joint, 5 deg inside
        line = rig.wait_log("joint shoulder goal beyond its limits [", "(joints.shoulder.limits.position): clamped",
                            since=mark)
        low, high = (float(v) for v in line.split("limits [")[1].split("]")[0].split(","))
        assert (low, high) == pytest.approx((math.radians(-85), math.radians(45)), abs=2 * TWO_PULSES_RAD), line
    finally:
        assert rig.close() == 0


# ---------------------------------------------------------------------------- refusals
def test_refusals_before_anything_is_done(bus, tmp_path):
    hold(bus, 1)
    target = tmp_path / "joints.yaml"
    for args, code, words in (
            (("1",), 2, ("ID 1: torque is on and calibrate turns it off", "--torque-off", "nothing done")),
            (("1,9", "--torque-off"), 1, ("ID 9: no servo answers at 57600 bps", "nothing done")),
            (("1,2", "--names", "a", "--torque-off"), 2, ("--names gives 1 name(s) for 2 servo(s)",)),
            (("7", "--homing-offset"), 2, ("ID 7 (AX-12A): it answers Protocol 1.0: --homing-offset refused",)),
            (("8", "--homing-offset"), 2, ("ID 8 (XL-320): the model has no Homing Offset: --homing-offset refused",))):
        run = calibrate(bus, *args, "--joints", str(target), bps=1_000_000 if args[0] in "78" else 57600)
        assert finished(run) == code, (args, run.lines)
        line = error_line(run)
        assert all(w in line for w in words), (args, line)
    assert not target.exists()
    target.write_text("kept\n")
    run = calibrate(bus, "2", "--joints", str(target))
    assert finished(run) == 2 and "the file exists: refused, nothing done (give --force" in error_line(run)
    assert target.read_text() == "kept\n"
    assert sdk_read(bus.path, 57600, 1, TORQUE, 1) == 1  # still holding its load


def test_a_range_smaller_than_the_margins_is_refused_naming_the_joint(bus, tmp_path):
    target = tmp_path / "joints.yaml"
    run = calibrate(bus, "1,2", "--joints", str(target), "--names", "shoulder,elbow", "--margin-deg", "10")
    try:
        run.wait_for(RECORD)
        set_angle(bus, 1, -40.0)
        set_angle(bus, 1, 40.0)
        set_angle(bus, 2, 5.0)  # 5 deg from where it started: less than 2 x 10 deg
        run.send("")
        assert finished(run) == 1
    finally:
        run.stop()
    line = error_line(run)
    assert "elbow (ID 2): moved through 5.0" in line and "--margin-deg" in line, line
    assert f"{target} not written; torque left off on ID 1, 2" in line, line
    assert not target.exists() and not list(tmp_path.iterdir())


@pytest.mark.parametrize("signum, stage", [(signal.SIGINT, RECORD), (signal.SIGTERM, ZERO)],
                         ids=["SIGINT-recording", "SIGTERM-zero-pose"])
def test_a_signal_names_each_servo_and_writes_no_file(bus, tmp_path, signum, stage):
    hold(bus, 1)
    target = tmp_path / "joints.yaml"
    run = calibrate(bus, "1,2", "--joints", str(target), "--torque-off", "--yes")
    try:
        run.wait_for(RECORD)
        for dxl_id, deg in ((1, 30.0), (1, -30.0), (2, 30.0), (2, -30.0)):
            set_angle(bus, dxl_id, deg)
        if stage == ZERO:
            run.send("")
            run.wait_for(ZERO)
        run.proc.send_signal(signum)
        assert finished(run) == 130
    finally:
        run.stop()
    line = error_line(run)
    assert line.startswith(f"error: interrupted ({signum.name}); state: ID 1 (XM430-W350) at 57600 bps, torque off "
                           "(it was on: the load is not held): nothing written | ID 2 (XM540-W270) at 57600 bps, "
                           "torque off: nothing written"), line
    assert line.endswith(f"{target} not written"), line
    assert not target.exists() and not list(tmp_path.iterdir())
    assert sdk_read(bus.path, 57600, 1, TORQUE, 1) == 0
