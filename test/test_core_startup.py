"""Start-up fails fast with one clear line and a non-zero exit code; SIGINT stops the servos as
term/* say and exits 0."""
from __future__ import annotations

import pytest

from dynamixel_handler.sim import VirtualBus

from support.rig import BASE_PARAMS, FOUR_SERVOS, H54, PH54, WRITE, XM430, XM540, Rig
from support.ros import NodeProcess, node_command


def _start_fails(servos: dict[int, int] | None, *params: str, device: str | None = None) -> tuple[int, str, list]:
    """Run the node on a virtual bus (or ``device``) and return its exit code, output and the bus log."""
    sim = VirtualBus(servos=servos or {})
    path = sim.start()
    try:
        node = NodeProcess(node_command(f"device_name:={device or path}", *BASE_PARAMS, *params))
        code = node.wait_exit(timeout=30)
        return code, node.output, sim.log
    finally:
        sim.close()


def _fatal_line(output: str) -> str:
    lines = [line for line in output.splitlines() if "[FATAL]" in line]
    assert len(lines) == 1, output
    return lines[0]


def test_missing_device():
    code, output, _ = _start_fails(None, device="/dev/ttyDXL_not_plugged")
    assert code == 1
    assert "/dev/ttyDXL_not_plugged does not exist" in _fatal_line(output)
    assert "Traceback" not in output


def test_no_servo_in_the_scanned_ids():
    code, output, log = _start_fails({20: XM430, 30: XM540})
    assert code == 1
    line = _fatal_line(output)
    assert "found 0 servo(s)" in line and "expected at least 1" in line and "IDs (0..6)" in line
    assert "Traceback" not in output
    assert not any(e.instruction == WRITE for e in log)


def test_fewer_servos_than_expected_after_the_retries():
    code, output, _ = _start_fails({1: XM430, 2: XM540}, "init/expected_servo_num:=3",
                                   "init/servo_auto_search.retry_times:=2")
    assert code == 1
    assert "found 2 servo(s)" in _fatal_line(output) and "expected 3" in _fatal_line(output)
    assert "scan 3/3 of IDs 0..6" in output  # it did retry as asked
    assert "Traceback" not in output


def test_only_servos_of_series_not_enabled():
    code, output, log = _start_fails({1: PH54, 2: H54}, "init/used_servo_series.P:=false",
                                     "init/used_servo_series.Pro:=false")
    assert code == 1
    assert "ID 1: PH54-200-S500-R is series P, which init/used_servo_series does not enable: skipped" in output
    assert "enable their series in init/used_servo_series" in _fatal_line(output)
    assert "Traceback" not in output
    assert not any(e.instruction == WRITE for e in log)  # the skipped servos were not touched


@pytest.mark.parametrize("param, needle", [
    ("loop_rate:=0", "parameter 'loop_rate' = 0 must be 1..2000 Hz"),
    ("pub_ratio/goal:=-3", "parameter 'pub_ratio/goal' = -3 must be >= 0"),
])
def test_bad_parameter_with_a_real_bus(param, needle):
    code, output, log = _start_fails({1: XM430}, param)
    assert code == 2
    assert needle in _fatal_line(output)
    assert "Traceback" not in output
    assert not log  # nothing was sent to the bus


# ---------------------------------------------------------------------------------------- SIGINT
def _moving_servos(bench: Rig) -> None:
    """ID 1 (X) and ID 4 (old Pro) turn in velocity mode, ID 3 (P) pushes in current mode."""
    for dxl_id, mode, item, value in ((1, 1, "goal_velocity", 40), (3, 0, "goal_current", 500),
                                      (4, 1, "goal_velocity", -3000)):
        servo = bench.sim.servo(dxl_id)
        servo.write("operating_mode", mode)
        servo.write(item, value)
    status = bench.topics["state/status"]
    modes = ["velocity", "position", "current", "velocity"]
    bench.wait(lambda: (m := status.last()) is not None and list(m.mode) == modes,
               what="the modes in /dynamixel/state/status")
    assert bench.sim.servo(1).read("present_velocity") != 0


@pytest.mark.parametrize("torque_off, stop", [(True, True), (False, True), (True, False)])
def test_sigint_exits_0_and_leaves_the_servos_as_term_params_say(torque_off, stop):
    bench = Rig(FOUR_SERVOS, "pub_ratio/status:=1", f"term/torque_auto_disable:={str(torque_off).lower()}",
                f"term/servo_auto_stop:={str(stop).lower()}", base=BASE_PARAMS, state_topics=True)
    try:
        _moving_servos(bench)
        goal_2 = bench.sim.servo(2).read("goal_position")
        code = bench.stop_node()
        sim = bench.sim
        assert code == 0, bench.output
        assert "Traceback" not in bench.output
        for dxl_id in FOUR_SERVOS:
            assert sim.servo(dxl_id).read("torque_enable") == (0 if torque_off else 1), f"ID {dxl_id}"
        goals = (sim.servo(1).read("goal_velocity"), sim.servo(3).read("goal_current"),
                 sim.servo(4).read("goal_velocity"))
        assert goals == ((0, 0, 0) if stop else (40, 500, -3000))
        assert sim.servo(2).read("goal_position") == goal_2  # a position-mode servo keeps its goal
        if stop:  # the bus watchdog that guards a crashed node is switched off on a clean exit
            assert [sim.servo(i).read("bus_watchdog") for i in (1, 2, 3)] == [0, 0, 0]
    finally:
        bench.close()


@pytest.mark.parametrize("servos, shared_model", [
    ([(1, XM430), (2, XM430), (2, XM540)], "XM"),   # equal Return Delay Times: the replies garble
    ([(1, XM430), (2, XM430)], None),               # one servo alone: nothing to say
])
def test_two_servos_at_one_id_are_named_and_left_alone(servos, shared_model):
    """The start-up scan tells an ID that two servos answer at (their replies collide), in one
    line with what to do, and handles the others; nothing is written to the shared ID."""
    sim = VirtualBus(servos=servos)
    path = sim.start()
    # an FTDI's default latency (a reply wait of ~38 ms, not ~8): every round of the pings that
    # tell a shared ID must see the collision, and a virtual bus held back on a loaded host answers late
    node = NodeProcess(node_command(f"device_name:={path}", *BASE_PARAMS, "latency_timer:=16"))
    try:
        node.wait_for("loop running", timeout=30)
        output = node.output
        assert "latency_timer=16," in output
        shared = [line for line in output.splitlines() if "two or more servos answer at this ID" in line]
        if shared_model is None:
            assert not shared and "ID 2: XM430-W350" in output
            return
        assert len(shared) == 1 and "ID 2:" in shared[0] and "not handled" in shared[0]
        assert "dynamixel_handler_setup assign-ids" in shared[0] and "[ERROR]" in shared[0]
        assert "ID 1: XM430-W350" in output and "ID 2: XM" not in output.split("two or more")[1]
        assert not any(e.instruction == WRITE and 2 in e.ids for e in sim.log)
    finally:
        node.stop()
        sim.close()
