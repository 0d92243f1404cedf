"""Every line the node writes goes through its logger: a severity and the namespaced logger name
(`[robot1.dynamixel_handler]` in namespace robot1) on each line, from the start-up lines through a
failing loop to the last line at exit, and for a start-up that fails."""
from __future__ import annotations

import re
import signal

from lifecycle_msgs.msg import State, Transition
from test_lifecycle import Manager
from test_lifecycle import _command as lifecycle_command

from dynamixel_handler.sim import VirtualBus

from support.ros import NodeProcess, node_command

X, P = 1020, 2020
LINE = re.compile(r"^\[(DEBUG|INFO|WARN|ERROR|FATAL)\] \[\d+\.\d+\] \[robot1\.dynamixel_handler\]: \S")


def _in_robot1(cmd: list[str]) -> list[str]:
    return cmd + ["-r", "__ns:=/robot1"]


def _not_conforming(lines: list[str]) -> list[str]:
    return [ln for ln in lines if not LINE.match(ln)]


def test_start_up_fault_and_exit_lines_carry_severity_and_the_namespaced_logger():
    with VirtualBus({1: X, 2: P}) as sim:
        cmd = _in_robot1(node_command(f"device_name:={sim.path}", "latency_timer:=1", "init/used_servo_series.P:=true",
                                      "init/servo_auto_search.max_id:=2", "verbose_ratio:=20",
                                      "default/profile_acc:=1.5"))  # a parameter set: its own start-up line
        proc = NodeProcess(cmd, env={"DYNAMIXEL_HANDLER_INJECT_LOOP_FAULTS": "2"})
        proc.wait_for("handled", timeout=30)
        proc.wait_for(lambda s: "loop" in s and "fault injected" in s)  # a failing loop
        proc.wait_for("ms/loop")  # a statistics line after it
        assert proc.stop(signal.SIGINT) == 0, proc.output
    lines = proc.lines
    assert _not_conforming(lines) == [], proc.output
    assert any("default/profile_acc" in ln for ln in lines)  # the parameter block, one line each
    assert "Traceback" not in proc.output
    assert "stopping" in lines[-1] or any("stopping" in ln for ln in lines[-3:]), proc.output


def test_a_start_up_failure_is_one_fatal_line_of_the_namespaced_logger():
    proc = NodeProcess(_in_robot1(node_command("device_name:=/dev/null", "loop_rate:=0")))
    assert proc.wait_exit(timeout=30) == 2, proc.output
    assert _not_conforming(proc.lines) == [], proc.output
    assert [ln for ln in proc.lines if ln.startswith("[FATAL]")] == [proc.lines[-1]]
    assert "loop_rate" in proc.lines[-1]


def test_lifecycle_node_says_what_it_did_and_no_stopping_when_nothing_was_configured():
    with VirtualBus({1: X}) as sim:
        # never configured: no "stopping" at exit
        proc = NodeProcess(lifecycle_command(sim.path))
        proc.wait_for("waiting for the configure transition", timeout=30)
        assert proc.stop(signal.SIGINT) == 0, proc.output
        assert not any("stopping" in ln for ln in proc.lines), proc.output
        assert "nothing to stop" in proc.lines[-1]

        # configured, then the shutdown transition: its line says what it did (one servo here)
        proc = NodeProcess(lifecycle_command(sim.path, "init/expected_servo_num:=1"))
        mgr = Manager()
        try:
            proc.wait_for("waiting for the configure transition", timeout=30)
            assert mgr.transition(Transition.TRANSITION_CONFIGURE)
            assert mgr.transition(Transition.TRANSITION_INACTIVE_SHUTDOWN)
            assert mgr.state() == State.PRIMARY_STATE_FINALIZED
            line = proc.wait_for("shut down:")
            assert "IDs [1]" in line and "device closed" in line, proc.output
        finally:
            mgr.close()
            assert proc.stop(signal.SIGINT) == 0, proc.output
