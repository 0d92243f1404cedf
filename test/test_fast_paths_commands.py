"""The command path's fast paths against their plain counterparts: the same commands give the same
writes, registers and warnings.

- Goals and control commands (``commands.fast_path.FastGoals``): an ID list checked once per servo table
  (``Targets``), the servos' mode and items kept, the values converted in plain Python (a few
  servos) or through numpy (many), every goal position checked against bounds kept per table.
  The same command sequence on two fresh virtual buses, one with the fast path and one without,
  records the same goal writes handed to the core, the same registers on the simulated servos and
  the same warnings; the fast path must have handled some of the commands and left others.
- Goals look for tripped bus watchdogs (``Requests.put_goals``) only when the table shows one
  (answered once per new watchdog values); the sequence above ends with a trip.
- The conversion in plain Python equals ``units.unit_to_pulse`` for any finite value.
"""
from __future__ import annotations

import logging
import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dynamixel_handler import units
from dynamixel_handler.commands import Commander, CommandPaths, goal_bounds
from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.servo.table import ServoTable
from dynamixel_handler.sim import VirtualBus

from support.handler_bench import capture_log, handler_on_virtual_bus
from support.rig import PRO, X540, P, X
from support.ros import SCAN_RETRIES
from support.servo_access import attached

XL430 = 1060
SERVOS = {1: X, 2: X540, 3: P, 4: PRO, 5: XL430}
REGISTERS = ("goal_position", "goal_velocity", "goal_current", "goal_pwm", "profile_velocity",
             "profile_acceleration", "operating_mode")


def _steps(c: Commander, sim: VirtualBus) -> list:
    nan, inf = float("nan"), float("inf")
    return [
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [10.0, 40.0]}),
        lambda: c.control("X", "position_control", [1, 2, 5], {"position_deg": [11.0, 41.0, -30.0],
                                                              "profile_vel_deg_s": [90.0, 180.0, 45.0],
                                                              "profile_acc_deg_ss": [500.0, 1e9, 20.0]}),
        lambda: c.control("X", "position_control", np.array([2, 1], dtype=np.uint16),
                          {"position_deg": list(np.array([-12.5, 12.5]))}),
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [400.0, -400.0]}),  # clamped
        lambda: c.control("X", "position_control", [1, 1, 2], {"position_deg": [1.0, 2.0, 3.0]}),  # repeated
        lambda: c.control("X", "position_control", [1, 9], {"position_deg": [5.0, 6.0]}),  # unknown
        lambda: c.control("X", "position_control", [1, 3], {"position_deg": [5.0, 6.0]}),  # other series
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [nan, 7.0]}),
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [8.0, inf]}),
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [1e308, 1e308]}),
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [8.0, 9]}),  # an int among floats
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": ["8", "9"]}),  # no numbers
        lambda: c.goal([1, 2, 3, 4, 5], {"position_deg": [-20.0, 30.0, 170.0, 1e4, 5.0]}),
        lambda: c.goal([1, 2, 3, 4], {"position_deg": [1.0, 2.0, 3.0, 4.0], "rotation": [1.0, 1.0, 1.0, 1.0]}),
        lambda: c.goal([1, 2, 5], {"current_ma": [100.0, 200.0, 50.0]}),  # XL430: no current
        lambda: c.goal([1, 2], {"current_ma": [1e5, -1e5], "pwm_percent": [50.0, 200.0], "unknown": [1.0, 2.0]}),
        lambda: c.goal([1, 2], {"velocity_deg_s": [30.0, -1e6], "acceleration_deg_ss": [100.0, 200.0]}),
        lambda: c.goal([], {"position_deg": []}),
        lambda: c.control("X", "extended_position_control", [2, 1], {"position_deg": [1e6, -720.0]}),  # mode change
        lambda: c.control("X", "extended_position_control", [2, 1], {"position_deg": [100.0, -100.0],
                                                                       "rotation": [2.0, 300.0]}),
        lambda: c.control("X", "extended_position_control", [1, 2], {"position_deg": [3e6, -50.0]}),
        lambda: c.control("X", "position_control", [1, 2], {"position_deg": [1.0, 2.0]}),  # back: mode change
        # limits the wrong way round on servo 1: its register range applies (X)
        lambda: (sim.servo(1).write("min_position_limit", 3000), sim.servo(1).write("max_position_limit", 1000)),
        lambda: c.goal([1, 2], {"position_deg": [170.0, -5.0]}),
        lambda: c.control("X", "velocity_control", [1, 2], {"velocity_deg_s": [20.0, 1e5]}),
        lambda: c.control("X", "velocity_control", [1, 2], {"velocity_deg_s": [-20.0, 30.0]}),
        lambda: c.control("X", "current_control", [1, 5], {"current_ma": [10.0, 10.0]}),  # XL430 has no current
        lambda: c.control("P", "position_control", [3], {"position_deg": [-500.0], "velocity_deg_s": [50.0]}),
        lambda: c.control("PRO", "position_control", [4], {"position_deg": [45.0], "velocity_deg_s": [30.0]}),
        lambda: c.control("PRO", "velocity_control", [4], {"velocity_deg_s": [30.0]}),
        lambda: c.control("PRO", "velocity_control", [4], {"velocity_deg_s": [35.0]}),
        lambda: c.control("P", "extended_position_control", [3], {"position_deg": [1e6]}),
        lambda: c.goal([3, 4], {"position_deg": [-1e6, -170.0]}),
        lambda: c.goal([5, 4, 3, 2, 1], {"position_deg": [1.5, 2.5, 3.5, 4.5, 5.5]}),
        lambda: c.control("X", "velocity_control", [1, 2], {"velocity_deg_s": [5.0, 5.0]}),
        # servo 1's bus watchdog trips while the bus is silent: the next goals clear it first
        lambda: (time.sleep(1.5), c.h.read_item(1, "bus_watchdog"),
                 c.control("X", "velocity_control", [1, 2], {"velocity_deg_s": [6.0, 6.0]})),
    ]


def _run(fast: bool, small: int, monkeypatch) -> tuple[list, list[dict], list[str], list[bool]]:
    """The command sequence on a fresh virtual bus: the goal writes the commands handed to the
    core, the registers after each command, every warning and error line, and what the fast path
    answered each time it was asked."""
    config = {"mode_change_interval_sec": 0.0, "pub_ratio/limit": 1, "pub_ratio/status": 1,
              "init/used_servo_series.P": True, "init/used_servo_series.Pro": True,
              "init/servo_auto_search.retry_times": SCAN_RETRIES, "init/expected_servo_num": 5}
    with handler_on_virtual_bus(SERVOS, config, baudrate=1_000_000, patient=True, tripped_once=fast) as (sim, handler):
        lines = capture_log(handler, f"fast_commands_{fast}_{small}", lambda r: f"{r.levelname} {r.getMessage()}")
        handler.log.setLevel(logging.INFO)
        commander = attached(Commander(handler, CommandPaths(targets=fast, small=small)))
        writes: list = []
        set_goals = handler.core.set_goals

        def record(goals, what="goals"):  # the goals the command side hands to the core, in order
            writes.append([(item, list(values.items())) for item, values in goals.items()])
            return set_goals(goals, what)
        handler.core.set_goals = record  # type: ignore[method-assign]
        answers: list[bool] = []
        fast_goals = commander.fast.goals

        def asked(*args, **kwargs) -> bool:
            answers.append(fast_goals(*args, **kwargs))
            return answers[-1]
        commander.fast.goals = asked  # type: ignore[method-assign]
        registers = []
        for step in _steps(commander, sim):
            step()
            handler.step()
            handler.step()
            registers.append({i: {r: sim.servo(i).read(r) for r in REGISTERS if sim.servo(i).model.has(r)}
                              for i in SERVOS})
        handler.shutdown()
        return writes, registers, lines, answers


@pytest.mark.parametrize("small", [32, 0], ids=["plain Python", "numpy"])
def test_commands_through_the_fast_path_equal_servo_by_servo(small, monkeypatch):
    fast = _run(True, small, monkeypatch)
    plain = _run(False, small, monkeypatch)
    assert fast[0] == plain[0]  # the same goal writes, in the same order
    assert fast[1] == plain[1]  # the same registers after every command
    assert fast[2] == plain[2]  # the same warnings, errors and mode change lines
    assert fast[3].count(True) >= 12 and fast[3].count(False) >= 12, fast[3]  # both paths were used
    assert not any(plain[3])
    assert sum("clamped" in line for line in plain[2]) >= 5, plain[2]
    assert sum("refused" in line for line in plain[2]) >= 2, plain[2]
    assert any("operating mode -> ex_position" in line for line in plain[2]), plain[2]
    assert any("ID 1: bus watchdog had tripped" in line for line in plain[2]), plain[2]
    assert fast[1][0][1]["goal_position"] == 2048 + round(10 / (360 / 4096))  # a goal within bounds as sent


MODELS = [model_by_number(n) for n in (X, X540, P, PRO, XL430)]
ITEMS = ("goal_position", "goal_velocity", "goal_current", "goal_pwm", "profile_velocity", "profile_acceleration")


@settings(max_examples=300, deadline=None)
@given(picks=st.lists(st.tuples(st.sampled_from(range(len(MODELS))),
                                st.floats(allow_nan=False, allow_infinity=False)), min_size=1, max_size=6),
       item=st.sampled_from(ITEMS))
def test_plain_python_conversion_equals_unit_to_pulse(picks, item):
    table = ServoTable()
    ids = tuple(range(1, len(picks) + 1))
    for dxl_id, (model, _) in zip(ids, picks):
        table.add(dxl_id, MODELS[model])
    plan = goal_bounds.Targets(table, ids)
    values = [value for _, value in picks]
    if not plan.has(item):
        with pytest.raises(ValueError):
            units.unit_to_pulse(plan.models, item, values)
        return
    pulses, _ = plan.to_pulses(item, values, None)
    expected = units.unit_to_pulse(plan.models, item, values).tolist()
    assert pulses == expected
    assert all(type(p) is int for p in pulses)


def test_values_the_sum_check_lets_through_are_finite():
    """``_work`` checks finiteness by one sum: any NaN or infinity makes it non-finite (a sum
    that overflows only sends finite values the per-servo way)."""
    for values in ([1.0, float("nan")], [float("inf"), -float("inf")], [1e308, 1e308], [float("-inf"), 2.0]):
        assert not math.isfinite(sum(values))


# ============================================================================ bundles
def _bundles() -> list:
    from dynamixel_handler_msgs.msg import DxlCommandsAll, DxlCommandsX
    empty = DxlCommandsX()
    mixed = DxlCommandsX()
    mixed.position_control.id_list, mixed.position_control.position_deg = [1, 2], [10.0, 20.0]
    mixed.velocity_control.velocity_deg_s = [5.0]  # values without IDs: nothing to do
    mixed.gain.id_list, mixed.gain.position_p_gain_pulse = [1], [800, 900]  # lengths differ: warned
    mixed.limit.id_list, mixed.limit.temperature_limit_degc = [2], [70.0]
    too_many = DxlCommandsX()
    too_many.extended_position_control.id_list = [1] * 300  # refused as a whole
    too_many.status.id_list, too_many.status.torque = [1, 2], [True, True]
    ids_alone = DxlCommandsX()
    ids_alone.velocity_control.id_list = [2]  # switches the mode, writes no goal
    every = DxlCommandsAll()
    every.goal.id_list, every.goal.position_deg, every.goal.current_ma = [1, 2], [30.0, 40.0], [1.0]
    every.extra.id_list, every.extra.led.red_percent = [1], [100.0]
    return [("commands/x", empty), ("commands/x", mixed), ("commands/x", too_many), ("commands/x", ids_alone),
            ("commands/all", every), ("commands/all", DxlCommandsAll())]


def _run_bundles(skip: bool, monkeypatch) -> tuple[list[str], list[str], list[dict]]:
    """The bundles, as their bytes decode, handed to the node's handler of their topic: what was
    queued, the warnings and the registers after each."""
    import rclpy
    from rclpy.node import Node
    from rclpy.serialization import serialize_message

    from dynamixel_handler.ros import command_topics
    from dynamixel_handler.ros.cdr import Codec
    from dynamixel_handler.ros.intake import CommandIntake

    config = {"init/servo_auto_search.retry_times": SCAN_RETRIES,  # a reply lost on a loaded machine
              "mode_change_interval_sec": 0.0, "init/expected_servo_num": 2}
    context = rclpy.Context()
    node = None
    with handler_on_virtual_bus({1: X, 2: X540}, config, baudrate=1_000_000, patient=True) as (sim, handler):
        try:
            rclpy.init(context=context)
            node = Node(f"bundles_{skip}", context=context)
            lines = capture_log(handler, f"bundles_{skip}", lambda r: f"{r.levelname} {r.getMessage()}")
            handler.log.setLevel(logging.INFO)
            queued: list[str] = []
            submit = handler.submit

            def record(request, what="") -> None:
                queued.append(request.what)
                submit(request, what)
            handler.submit = record
            intake = CommandIntake(node, raw=True, detached=True)
            command_topics.CommandTopics(intake, attached(Commander(handler, CommandPaths(skip_empty=skip))), ("X",),
                                         command_line=False)
            handlers = {entry[3]: entry[2] for entry in intake._entries}
            registers = []
            for topic, msg in _bundles():
                handlers[f"dynamixel/{topic}"](Codec.of(type(msg)).decode(serialize_message(msg)))
                handler.step()
                handler.step()  # its reads are answered after the writes before them
                registers.append({i: {r: sim.servo(i).read(r) for r in ("goal_position", "goal_velocity", "operating_mode",
                                                                        "position_p_gain", "temperature_limit", "led")}
                                  for i in (1, 2)})
            intake.close()
            handler.shutdown()
            return queued, lines, registers
        finally:
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown(context=context)


def test_bundle_parts_without_ids_skipped_equal_every_part_handled(monkeypatch):
    skipped = _run_bundles(True, monkeypatch)
    every = _run_bundles(False, monkeypatch)
    assert skipped == every
    queued, lines, registers = skipped
    assert "x position_control" in queued and "x velocity_control" in queued
    assert any("'position_p_gain_pulse' has 2 values for 1 IDs" in line for line in lines), lines
    assert any("more than the 253" in line for line in lines), lines
    assert registers[1][1]["goal_position"] == 2048 + round(10 / (360 / 4096))


def test_ids_of_a_decoded_message_are_python_ints():
    from dynamixel_handler.ros.command_topics import unpack
    ids, fields = unpack({"id_list": np.array([1, 65535], dtype=np.uint16), "position_deg": np.array([1.0, 2.0])})
    assert ids == [1, 65535] and all(type(i) is int for i in ids)
    assert unpack({"id_list": [3, np.uint16(4)], "x": [1.0]})[0] == [3, 4]
    assert list(fields) == ["position_deg"]
