"""The E-stop part (``core.e_stop``) and the LED status (``core.led_status``), built over the real
parts on a fake bus (``support.parts``): the hold per mode, the gate of the core's typed calls, hold_all with a
fault that stays until it is read gone, and the LEDs written on a change only."""
from __future__ import annotations

import logging

from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.e_stop import GOAL_ITEMS, EStop
from dynamixel_handler.core.led_status import COLOURS, LedStatus
from dynamixel_handler.core.request_types import EngageStop, Outcome, ReleaseStop
from dynamixel_handler.settings import Settings

from support.fake_bus import PH54, XM430, FakeBus
from support.parts import Parts, build, lines_of


def started(name: str, servos=None, **changes) -> tuple[FakeBus, Parts, list[str]]:
    bus = FakeBus(servos or {1: XM430, 2: XM430})
    for dxl_id, mode in ((1, "position"), (2, "velocity")):
        if dxl_id in bus.models:
            bus.set(dxl_id, "operating_mode", OPERATING_MODES[mode])
    log, lines = lines_of(f"test_e_stop_part.{name}", logging.INFO)
    parts = build(bus, Settings().but(scan__max_id=max(servos or (2,)), **changes), log)
    parts.startup.start()
    parts.steps.step()
    parts.pending.take()
    bus.calls.clear()
    return bus, parts, lines


def test_engaging_holds_position_at_present_and_velocity_at_zero_dropping_waiting_goals():
    bus, parts, lines = started("hold")
    bus.set(1, "present_position", 1234)
    parts.pending.put("goal_position", {1: 3000})  # waiting: dropped, never written
    parts.pending.put("goal_velocity", {2: 50})
    assert isinstance(parts.e_stop, EStop)
    assert parts.e_stop.handle(EngageStop("test")).outcome is Outcome.DONE
    assert parts.pending.peek("goal_position") == {1: 1234} and parts.pending.peek("goal_velocity") == {2: 0}
    assert parts.e_stop.engaged_why() == "test" and parts.e_stop.changes == 1
    assert any(line.startswith("E-stop engaged (test): 2 servo(s) hold") for line in lines), lines
    assert parts.e_stop.handle(EngageStop("again")).outcome is Outcome.DONE and parts.e_stop.changes == 1  # no new hold


def test_the_gate_refuses_what_moves_and_lets_the_rest_through_until_the_release():
    bus, parts, lines = started("gate")
    parts.e_stop.handle(EngageStop("test"))
    calls = parts.core
    moving = {"goals": lambda: calls.set_goals({"goal_position": {1: 100}}, "x/position_control"),
              "torque on": lambda: calls.torque_on(1), "mode": lambda: calls.change_mode(1, "velocity"),
              "goal write": lambda: calls.write_item(2, "goal_velocity", 10),
              "torque write": lambda: calls.write_item(1, "torque_enable", 1)}
    for name, call in moving.items():
        assert call().outcome is Outcome.REFUSED, name
    still = {"gains": lambda: calls.set_goals({"position_p_gain": {1: 900}}, "gain"),
             "torque off": lambda: calls.torque_off(2), "led": lambda: calls.write_item(1, "led", 1)}
    for name, call in still.items():
        assert call().outcome is Outcome.DONE, name
    assert sum("x/position_control refused" in line for line in lines) == 1
    assert parts.e_stop.handle(ReleaseStop("test")).outcome is Outcome.DONE and parts.e_stop.engaged_why() is None
    assert parts.core.set_goals({"goal_position": {1: 100}}, "x/position_control").outcome is Outcome.DONE
    assert parts.pending.peek("goal_position") == {1: 100}
    assert set(GOAL_ITEMS) == {"goal_position", "goal_velocity", "goal_current", "goal_pwm"}


def test_hold_all_engages_on_a_fault_and_the_release_waits_until_it_is_read_gone():
    bus, parts, lines = started("hold_all", safety__on_hardware_error="hold_all")
    parts.table.set_value("hardware_error_status", 1, 0x20)
    parts.e_stop.watch()
    assert parts.e_stop.engaged_why() == "hardware error: ID 1 (XM430-W350): 0x20"
    refused = parts.e_stop.handle(ReleaseStop("test"))
    assert refused.outcome is Outcome.REFUSED and "ID 1: 0x20" in refused.failure
    parts.table.set_value("hardware_error_status", 1, 0)
    parts.e_stop.watch()
    assert parts.e_stop.handle(ReleaseStop("test")).outcome is Outcome.DONE


def _leds_pending(parts: Parts) -> dict:
    return {item: parts.pending.peek(item) for item in ("led", "led_red", "led_green", "led_blue")
            if parts.pending.peek(item)}


def test_leds_show_each_state_and_are_written_on_a_change_only():
    bus, parts, _ = started("leds", servos={1: XM430, 3: PH54}, safety__led_status=True, scan__used_series=("X", "P"))
    assert isinstance(parts.leds, LedStatus)
    # the first step's LED writes were taken away unwritten (``started``): the P's reads otherwise
    parts.leds.show()
    assert _leds_pending(parts) == {"led_red": {3: 0}, "led_green": {3: 255}, "led_blue": {3: 0}}
    parts.steps.step()  # written, then shown again at the end of the step: nothing new
    assert _leds_pending(parts) == {}
    parts.e_stop.handle(EngageStop("test"))
    parts.pending.drop_items(GOAL_ITEMS)
    parts.leds.show()
    red, green, blue = COLOURS["e_stop"]
    assert _leds_pending(parts) == {"led": {1: 1}, "led_red": {3: red}, "led_green": {3: green}, "led_blue": {3: blue}}
    parts.steps.step()
    assert _leds_pending(parts) == {}  # no change, no write
    parts.e_stop.handle(ReleaseStop("test"))
    parts.leds.show()
    red, green, blue = COLOURS["torque_on"]
    assert _leds_pending(parts) == {"led": {1: 0}, "led_red": {3: red}, "led_green": {3: green}, "led_blue": {3: blue}}
