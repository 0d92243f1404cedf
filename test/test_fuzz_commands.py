"""Property-based fuzzing of the command topics through real rclpy publishing.

Random id_lists (duplicates, unknown IDs, 0, 253, 254, 65535), arrays of every length, NaN, ±inf,
huge and negative values, empty and unknown strings. Invariants checked after the barrage, in
the same test: the node is up and keeps publishing at its rate, no servo refused a write (everything that reached
the wire was within its limits: the virtual servos refuse out-of-limit values, sync writes
included), and refused input was reported with the ID and the field.
"""
from __future__ import annotations

import math
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynamixel_handler_msgs.msg import (
    DxlCommandsAll,
    DxlCommandsP,
    DxlCommandsX,
    DynamixelControlPExtendedPosition,
    DynamixelControlProPosition,
    DynamixelControlXCurrent,
    DynamixelControlXCurrentBasePosition,
    DynamixelControlXExtendedPosition,
    DynamixelControlXPosition,
    DynamixelControlXPwm,
    DynamixelControlXVelocity,
    DynamixelGain,
    DynamixelGoal,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import PRO, X540, P, Rig, X

IDS = st.sampled_from([0, 1, 2, 3, 4, 9, 252, 253, 254, 65535])
FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                   st.sampled_from([0.0, -0.0, 1e300, -1e300, 1e9, -1e9, 90.0, -720.0, 5e4]),
                   st.floats(min_value=-400, max_value=400))
MODES = st.sampled_from(["pwm", "current", "velocity", "position", "ex_position", "cur_position", "", "POSITION", "warp"])
# (remove_id is left out: it would empty the handled set and leave nothing to check)
SHORTCUTS = st.sampled_from(["TON", "TOFF", "torque_on", "enable", "disable", "CE", "reboot", "", "explode", "ADID"])


def _array(strategy, n: int):
    # mostly the right length, sometimes any length (0..5)
    return st.one_of(st.lists(strategy, min_size=n, max_size=n), st.lists(strategy, max_size=5))


@st.composite
def control_messages(draw):
    typ = draw(st.sampled_from([DynamixelControlXPosition, DynamixelControlXExtendedPosition, DynamixelControlXVelocity,
                                DynamixelControlXCurrent, DynamixelControlXPwm, DynamixelControlXCurrentBasePosition,
                                DynamixelControlPExtendedPosition, DynamixelControlProPosition, DynamixelGoal]))
    ids = draw(st.lists(IDS, max_size=5))
    msg = typ(id_list=ids)
    for name, kind in typ.get_fields_and_field_types().items():
        if name != "id_list" and kind == "sequence<double>":
            setattr(msg, name, draw(_array(FLOATS, len(ids))))
    return msg


@st.composite
def status_messages(draw):
    ids = draw(st.lists(IDS, max_size=4))
    msg = DynamixelStatus(id_list=ids)
    msg.torque = draw(_array(st.booleans(), len(ids)))
    msg.mode = draw(_array(MODES, len(ids)))
    return msg


TOPIC = {
    DynamixelControlXPosition: "/dynamixel/command/x/position_control",
    DynamixelControlXExtendedPosition: "/dynamixel/command/x/extended_position_control",
    DynamixelControlXVelocity: "/dynamixel/command/x/velocity_control",
    DynamixelControlXCurrent: "/dynamixel/command/x/current_control",
    DynamixelControlXPwm: "/dynamixel/command/x/pwm_control",
    DynamixelControlXCurrentBasePosition: "/dynamixel/command/x/current_base_position_control",
    DynamixelControlPExtendedPosition: "/dynamixel/command/p/extended_position_control",
    DynamixelControlProPosition: "/dynamixel/command/pro/position_control",
    DynamixelGoal: "/dynamixel/command/goal",
    DynamixelStatus: "/dynamixel/command/status",
    DynamixelShortcut: "/dynamixel/shortcut",
    DynamixelLimit: "/dynamixel/command/limit",
    DynamixelGain: "/dynamixel/command/gain",
}


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: X540, 3: P, 4: PRO}, "mode_change_interval_sec:=0.0", "clear_error_interval_sec:=0.0",
            "pub_ratio/status:=5", "pub_ratio/limit:=20")
    yield r
    assert r.close() == 0


def _alive(rig: Rig) -> None:
    assert rig.node_proc.proc.poll() is None, rig.node_proc.output[-3000:]
    n = len(rig.debug)
    rig.wait(lambda: len(rig.debug) >= n + 10, timeout=10, what="the loop still publishing")
    assert "Traceback" not in rig.node_proc.output


MESSAGES = st.one_of(control_messages(), status_messages(),
                     st.builds(DynamixelShortcut, command=SHORTCUTS, id_list=st.lists(IDS, max_size=3)))


def test_random_commands_never_break_the_node_nor_reach_the_wire_out_of_limits(rig):
    """The barrage, then its invariants in the same test: the node is up and publishing, no servo
    refused a write, unknown IDs were reported, and the loop still runs at its rate."""
    sent: list[type] = []

    @settings(max_examples=120, deadline=None, database=None)
    @given(msg=MESSAGES)
    def barrage(msg) -> None:
        rig.publish(TOPIC[type(msg)], msg)
        sent.append(type(msg))
        time.sleep(0.01)

    barrage()
    assert len(sent) >= 100, f"only {len(sent)} messages were published"
    # a last message that only this test sends: once its line is logged, the loop has taken the
    # barrage before it (commands are taken in publish order) and run the requests it queued
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="fuzz-barrage-end", id_list=[1]))
    rig.node_proc.wait_for("shortcut: unknown command 'fuzz-barrage-end'")
    _alive(rig)  # ten more loops published: the mode changes and reboots of the barrage are done
    assert list(rig.sim.refused) == [], "writes the servos refused (out of their limits)"
    assert "is not handled: ignored" in rig.node_proc.output
    # the loop still runs at its rate: 100 Hz target, states published by the loop thread
    n, t0 = len(rig.debug), time.monotonic()
    time.sleep(1.0)
    rate = (len(rig.debug) - n) / (time.monotonic() - t0)
    assert rate > 30, f"debug published at {rate:.0f} Hz after the fuzzing"


def test_each_kind_of_bad_value_names_the_id_and_field(rig):
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1, 2, 9, 3], position_deg=[math.nan, math.inf, 0.0, 1.0]))
    rig.node_proc.wait_for("ID 1 'position_deg' = nan refused (not a finite number)")
    rig.node_proc.wait_for("ID 2 'position_deg' = inf refused (not a finite number)")
    rig.node_proc.wait_for("ID 9 is not handled: ignored")
    rig.node_proc.wait_for("ID 3 is PH54-200-S500-R (series P), not X: ignored")
    rig.publish("/dynamixel/command/x/position_control",
                DynamixelControlXPosition(id_list=[1], position_deg=[1.0, 2.0]))
    rig.node_proc.wait_for("'position_deg' has 2 values for 1 IDs: ignored")
    rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1], mode=["warp"]))
    rig.node_proc.wait_for("ID 1 unknown mode 'warp'")
    rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="explode"))
    rig.node_proc.wait_for("shortcut: unknown command 'explode'")
    rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[1], current_ma=[1e9]))
    rig.node_proc.wait_for("ID 1 (XM430-W350) 'current_ma' = 1e+09 is beyond the servo's limit: clamped to")
    rig.publish("/dynamixel/command/x/extended_position_control",
                DynamixelControlXExtendedPosition(id_list=[2], rotation=[1000.0]))
    rig.node_proc.wait_for("ID 2 'rotation' = 1000 is beyond ±256: clamped")
    _alive(rig)
    assert list(rig.sim.refused) == []


def test_bundled_messages_with_garbage_in_every_part(rig):
    cmd = DxlCommandsX()
    cmd.position_control.id_list = [1, 65535]
    cmd.position_control.position_deg = [math.nan]
    cmd.velocity_control.id_list = [254]
    cmd.velocity_control.velocity_deg_s = [1e300]
    cmd.status.id_list = [253]
    cmd.status.torque = [True, False]
    rig.publish("/dynamixel/commands/x", cmd)
    allc = DxlCommandsAll()
    allc.goal.id_list = [1, 2, 3, 4]
    allc.goal.velocity_deg_s = [-1e12, 1e12, math.nan, -math.inf]
    allc.limit.id_list = [3]
    allc.limit.max_position_limit_deg = [-10.0]
    allc.limit.min_position_limit_deg = [10.0]
    rig.publish("/dynamixel/commands/all", allc)
    p = DxlCommandsP()
    p.extended_position_control.id_list = [3]
    p.extended_position_control.rotation = [-300.0]
    rig.publish("/dynamixel/commands/p", p)
    rig.node_proc.wait_for("min position limit above max: position limits ignored")
    _alive(rig)
    assert list(rig.sim.refused) == []
