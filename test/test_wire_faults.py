"""Wire faults from the simulator: CRC corruption, garbage, truncated replies, a hardware error
appearing mid-run. The node survives, keeps publishing, and commands still reach the servos."""
from __future__ import annotations

import math
import time

import pytest

from dynamixel_handler_msgs.msg import DynamixelControlXPosition, DynamixelShortcut

from support.rig import X540, P, Rig, X


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: P}, "pub_ratio/status:=5", "pub_ratio/error:=5", "verbose_ratio:=50",
            "clear_error_interval_sec:=0.0")
    yield r
    assert r.close() == 0


def _still_publishing(rig: Rig, n: int = 20) -> None:
    start = len(rig.debug)
    rig.wait(lambda: len(rig.debug) >= start + n, timeout=15, what="the loop still publishing")


def _command_lands(rig: Rig, deg: float) -> None:
    rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1, 2], position_deg=[deg, -deg]))
    rig.wait(lambda: rig.sim.servo(1).read("goal_position") == 2048 + round(deg * 4096 / 360)
             and rig.sim.servo(2).read("goal_position") == 2048 - round(deg * 4096 / 360),
             timeout=15, what=f"goal {deg} deg on the wire")


@pytest.mark.parametrize("rate", [0.01, 0.1])
def test_crc_corruption(rig, rate):
    mark = rig.mark()
    rig.sim.crc_error_rate = rate
    try:
        _still_publishing(rig, 60)
        _command_lands(rig, 10.0 + 100 * rate)
        line = rig.wait_log("success=", since=mark, timeout=15)
        assert "success=" in line
    finally:
        rig.sim.crc_error_rate = 0.0
    _still_publishing(rig)
    assert all(rig.debug[-1].status.ping)
    assert rig.node_proc.proc.poll() is None


def test_garbage_and_truncated_replies(rig):
    for k in range(20):
        rig.sim.inject_garbage(40)
        rig.sim.truncate_next(2)
        time.sleep(0.02)
    _still_publishing(rig)
    _command_lands(rig, -33.0)
    rig.wait(lambda: all(rig.debug[-1].status.ping), what="all servos answering again")
    assert not any(math.isnan(v) for v in rig.debug[-1].position_deg.present)


def _answering_for(rig, seconds: float) -> None:
    """Wait until every servo has answered in every debug message of the last ``seconds`` (the
    truncated replies queued by an earlier test are used up)."""
    def steady() -> bool:
        recent = rig.debug.since(time.monotonic() - seconds)
        return len(recent) >= 3 and all(all(m.status.ping) for m in recent)
    rig.wait(steady, timeout=30, what=f"every servo answering for {seconds} s")


def test_hardware_error_mid_run_is_reported_and_cleared(rig):
    _answering_for(rig, 1.0)
    rig.sim.set_hardware_error(2, 0x20)  # overload: the shutdown mask drops torque
    rig.wait(lambda: rig.debug_of(2)["error"], timeout=10, what="error flag of ID 2")
    rig.node_proc.wait_for("ID 2: hardware error overload (0x20)")
    assert rig.sim.servo(2).read("torque_enable") == 0
    assert not rig.debug_of(1)["error"]
    _still_publishing(rig)
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[2]))
    rig.wait(lambda: not rig.debug_of(2)["error"], timeout=15, what="error cleared")
    assert rig.sim.servo(2).read("hardware_error_status") == 0
