"""Joint offsets measured from outside, through the real node on the virtual bus: the service
``dynamixel/calibrate_offsets`` makes the measured joint read its measurement at once (no servo
written), saves the offsets to ``joints_calibration.path`` and the next start loads them; bad
requests are refused with the offsets kept. Effort in N·m (``joint_state.effort_unit: Nm``) read
and commanded through the model's torque per ampere. A multi-turn servo that loses its power (on its own,
or with its adapter) comes back at its position, not within one turn, and set up again; one rebooted
through ``dynamixel/reboot_servos`` keeps its position too."""
from __future__ import annotations

import math
import time

import pytest
from sensor_msgs.msg import JointState

from dynamixel_handler.core.deferred import EEPROM_WRITE_INTERVAL_S
from dynamixel_handler_msgs.msg import DynamixelShortcut
from dynamixel_handler_msgs.srv import CalibrateOffsets, RebootServos

from support.rig import Rig, X, power_cycle, turn_by_hand

TURN = 4096
#: servos 3 and 4 in extended position mode, three turns and a bit from their zero before the node starts
START_3 = 3 * TURN + 300


def block(path) -> tuple[str, ...]:
    return ("joints.shoulder.id:=1", "joints.shoulder.reduction:=2.0", "joints.gripper.id:=2",
            "joints.gripper.type:=prismatic", "joints.gripper.stroke:=[0.0, 0.04]", "joints.gripper.servo_deg:=[0.0, 100.0]",
            "joints.finger.mimic:=gripper", f"joints_calibration.path:={path}", "servos.id_3.mode:=ex_position",
            "servos.id_4.mode:=ex_position", "joint_state.effort_unit:=Nm",
            "loop_rate:=100")


def _before(sim) -> None:
    for dxl_id in (3, 4):
        with sim._lock:
            sim.servo(dxl_id).write("operating_mode", 4)  # extended position
        turn_by_hand(sim, dxl_id, START_3 - sim.servo(dxl_id).read("present_position"))


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    path = tmp_path_factory.mktemp("calibration") / "joints.yaml"
    r = Rig({1: X, 2: X, 3: X, 4: X}, *block(path), before_start=_before)
    r.calibration_file = path
    with r._lock:
        r.joint_states = []
        r.node.create_subscription(JointState, "/joint_states", r.joint_states.append, 50)
    yield r
    assert r.close() == 0


def joints_now(rig: Rig, **expected: float) -> None:
    """Wait until joint_states says ``expected`` (joint: position)."""
    def there() -> bool:
        if not rig.joint_states:
            return False
        at = dict(zip(rig.joint_states[-1].name, rig.joint_states[-1].position))
        return all(abs(at.get(n, math.inf) - v) < 1e-3 for n, v in expected.items())
    rig.wait(there, timeout=15, what=f"joint_states at {expected}")


def calibrate(rig: Rig, names, positions) -> CalibrateOffsets.Response:
    return rig.call(CalibrateOffsets, "/dynamixel/calibrate_offsets",
                    CalibrateOffsets.Request(joint_names=list(names), positions=list(positions)))


def at_rest(rig: Rig, *ids: int) -> bool:
    """The servos' present positions did not change for 0.2 s (a joint measured while it moves
    would read its measurement for an instant only)."""
    before = [rig.sim.servo(i).read("present_position") for i in ids]
    time.sleep(0.2)
    return [rig.sim.servo(i).read("present_position") for i in ids] == before


def test_a_measured_joint_reads_its_measurement_its_servo_untouched_and_the_offsets_are_saved(rig):
    rig.wait(lambda: at_rest(rig, 1, 2), timeout=15, what="servos 1 and 2 at rest (a command before may move them)")
    goal = rig.sim.servo(1).read("goal_position")
    writes = len(rig.transactions())
    res = calibrate(rig, ["shoulder", "gripper"], [0.3, 0.015])
    assert res.success and res.saved and res.path == str(rig.calibration_file), res.message
    assert "shoulder: offset " in res.message and "saved to" in res.message  # from 0, or what a test before set
    joints_now(rig, shoulder=0.3, gripper=0.015, finger=0.015)
    assert rig.sim.servo(1).read("goal_position") == goal  # nothing moved, nothing written but reads
    assert not [e for e in rig.transactions()[writes:] if e.instruction in (0x03, 0x83) and 1 in e.ids]
    text = rig.calibration_file.read_text()
    assert '"shoulder": ' in text and '"gripper": ' in text
    assert res.offsets == pytest.approx([0.3 - 2 * 0.0, 0.015 - 0.0], abs=0.2)  # near: the servos sit near 0


@pytest.mark.parametrize("names, positions, why", [
    (["knee"], [0.1], "refused: unknown joint 'knee' (known: "),
    (["finger"], [0.1], "refused: finger is a mimic joint (state only)"),
    (["shoulder"], [math.nan], "refused: shoulder: position nan is not a finite number"),
    (["shoulder"], [0.1, 0.2], "refused: 1 joint names but 2 positions"),
])
def test_a_request_that_cannot_be_right_is_refused_and_the_offsets_kept(rig, names, positions, why):
    before = rig.calibration_file.read_text() if rig.calibration_file.exists() else ""
    res = calibrate(rig, names, positions)
    assert not res.success and not res.saved and res.message.startswith(why), res.message
    assert (rig.calibration_file.read_text() if rig.calibration_file.exists() else "") == before


def test_the_next_start_loads_the_saved_offsets(rig):
    res = calibrate(rig, ["shoulder"], [-0.2])
    assert res.success and res.saved, res.message
    joints_now(rig, shoulder=-0.2)
    assert rig.stop_node() == 0
    rig.joint_states.clear()
    rig.start_node(*block(rig.calibration_file))
    rig.wait_log("joint offsets of ", "loaded from")
    joints_now(rig, shoulder=-0.2)


def test_a_multi_turn_servo_that_lost_its_power_comes_back_at_its_position(rig):
    def near_start(dxl_id: int = 3) -> bool:
        return abs(rig.sim.servo(dxl_id).read("present_position") - START_3) < 40
    rig.wait(lambda: near_start(3) and near_start(4), timeout=10, what="servos 3 and 4 three turns from their zero")
    # its own power: silent, booted (within one turn), answering again
    mark = rig.mark()
    rig.sim.set_silent(3, True)
    rig.wait_log("ID 3: no response", since=mark)
    power_cycle(rig.sim, 3)
    assert abs(rig.sim.servo(3).read("present_position") - START_3) > TURN  # the boot lost the turns
    rig.sim.set_silent(3, False)
    line = rig.wait_log("whole turns lost at boot given back", since=mark)
    assert "ID 3: +3 whole turns" in line
    # it lost its RAM with its power: set up again, torque on as it was, holding where it is
    rig.wait_log("ID 3: answers again after a power loss (RAM at its defaults): set up again, torque on as it was",
                 since=mark)
    rig.wait(lambda: rig.sim.servo(3).read("torque_enable") == 1, timeout=10, what="servo 3's torque back on")
    rig.wait(near_start, timeout=10, what="servo 3 back at its position")
    # with its adapter: the device gone and back, servo 4 booted meanwhile (3 kept its power: left alone)
    mark = rig.mark()
    rig.sim.vanish()
    rig.wait_log("is gone", since=mark)
    power_cycle(rig.sim, 4)
    rig.sim.reappear()
    rig.wait_log("is back: reconnected", since=mark, timeout=20)
    line = rig.wait_log("ID 4: +3 whole turns lost at boot given back", since=mark, timeout=20)
    assert "ID 3: " not in "".join(x for x in line.splitlines() if "turns" in x)
    rig.wait(lambda: near_start(4), timeout=10, what="servo 4 back at its position after the reconnect")


def test_a_multi_turn_servo_rebooted_through_the_node_keeps_its_position(rig):
    servo = rig.sim.servo(4)
    rig.wait(lambda: abs(servo.read("present_position") - START_3) < 40, timeout=10, what="servo 4 three turns from its zero")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_off", id_list=[4]))
    rig.wait(lambda: servo.read("torque_enable") == 0, what="servo 4's torque off")
    turn_by_hand(rig.sim, 4, 2 * TURN)  # two turns more, by hand: its count now beyond its Homing Offset's turn
    moved, offset = servo.read("present_position"), servo.read("homing_offset")
    time.sleep(EEPROM_WRITE_INTERVAL_S)  # a Homing Offset the test before gave back is written no sooner than this
    mark = rig.mark()
    res = rig.call(RebootServos, "/dynamixel/reboot_servos", RebootServos.Request(ids=[4]))
    assert res.success and list(res.torque_on) == [False], (res.message, list(res.errors))
    line = rig.wait_log("ID 4: +", since=mark)
    assert "whole turns lost at boot given back through its Homing Offset" in line, line
    turns = (servo.read("homing_offset") - offset) // TURN
    assert turns >= 2 and servo.read("homing_offset") == offset + turns * TURN  # one EEPROM write holds them
    assert abs(servo.read("present_position") - moved) < 40  # it reads where it was, not within one turn
    # as the other tests of the module found it: Homing Offset 0 (set on the virtual servo, as a
    # tool would), three turns from its zero, holding
    servo.write("homing_offset", 0)
    turn_by_hand(rig.sim, 4, START_3 - servo.read("present_position"))
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="torque_on", id_list=[4]))
    rig.wait(lambda: servo.read("torque_enable") == 1, what="servo 4's torque back on")


def test_effort_is_read_and_commanded_in_nm_through_the_model_s_torque_per_ampere(rig):
    servo = rig.sim.servo(1)
    per_amp = 4.1 / 2.3  # XM430-W350 (e-Manual: stall torque 4.1 N·m at 2.3 A, 12 V)
    with rig.sim._lock:
        servo.pin("present_current", 200)
    try:
        expected = 200 * servo.model.current_ma_per_pulse / 1000.0 * per_amp * 2.0  # reduction 2

        def effort() -> float:
            msg = rig.joint_states[-1] if rig.joint_states else None
            return dict(zip(msg.name, msg.effort)).get("shoulder", math.nan) if msg is not None else math.nan
        rig.wait(lambda: abs(effort() - expected) < 1e-6, timeout=15, what=f"shoulder's effort {expected:.4f} N·m")
    finally:
        with rig.sim._lock:
            servo.pin("present_current", None)
    # the gripper (metres): 10 N through its stroke of 4 cm over 100 deg is a current of
    amps = 10.0 / (per_amp * math.radians(1.0) / (0.04 / 100.0))
    rig.publish("/joint_commands", JointState(name=["gripper"], position=[0.02], effort=[10.0]))
    pulses = round(amps * 1000.0 / rig.sim.servo(2).model.current_ma_per_pulse)
    rig.wait(lambda: abs(rig.sim.servo(2).read("goal_current") - pulses) <= 1, timeout=15,
             what=f"servo 2's Goal Current at {pulses} (10 N)")
