"""``commands.tables``: what the command messages mean. Every shortcut name, short or long, does
what its action does; every control topic puts a servo in its mode; every goal field reaches its
control-table item; the modes that need a current sensor are refused on a servo without one."""
import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.tables import CONTROL_MODES, CURRENT_MODES, GOAL_FIELDS, SHORTCUTS

from support.servo_access import FakeAccess, attached, warnings_of

XM430, XL430 = 1020, 1060
VALUES = {"min_position_limit": {1: 0, 2: 0}, "max_position_limit": {1: 4095, 2: 4095},
          "velocity_limit": {1: 200, 2: 200}, "current_limit": {1: 1193}, "pwm_limit": {1: 885, 2: 885},
          "acceleration_limit": {1: 32767, 2: 32767}, "torque_enable": {1: 0, 2: 0}}


def _commander(modes=None):
    access = FakeAccess({1: XM430, 2: XL430}, modes=modes, values=VALUES)
    lines = warnings_of(access)
    return attached(Commander(access)), access, lines


@pytest.mark.parametrize("name", [n for n, action in SHORTCUTS.items() if n != action])
def test_a_short_shortcut_name_makes_the_requests_of_its_action(name):
    short, long = _commander(), _commander()
    short[0].shortcut(name, [1])
    long[0].shortcut(SHORTCUTS[name], [1])
    assert short[1].calls == long[1].calls and short[1].calls
    assert short[2] == long[2] == []


@pytest.mark.parametrize("control", sorted(CONTROL_MODES))
def test_a_control_topic_switches_the_servo_to_its_mode(control):
    mode = CONTROL_MODES[control]
    c, access, lines = _commander(modes={1: "velocity" if mode != "velocity" else "position"})
    c.control("X", control, [1], {})
    assert access.calls[-1] == ("change_mode", 1, mode) and access.mode(1) == mode and not lines


@pytest.mark.parametrize("field", sorted(GOAL_FIELDS))
def test_a_goal_field_is_written_to_its_item(field):
    c, access, lines = _commander()
    c.goal([1], {field: [100.0]})  # (1 deg/s^2 is under one profile step: written as one, with a line)
    assert [set(goals) for goals in access.goals] == [{GOAL_FIELDS[field]}] and not lines


@pytest.mark.parametrize("mode", sorted(CURRENT_MODES))
def test_a_mode_that_needs_a_current_sensor_is_refused_on_a_servo_without_one(mode):
    control = next(c for c, m in CONTROL_MODES.items() if m == mode)
    c, access, lines = _commander()
    c.control("X", control, [2], {"current_ma": [10.0]})
    assert access.goals == [] and not any(call[0] == "change_mode" for call in access.calls)
    assert lines == [f"x/{control}: ID 2 (XL430-W250) has no current sensor, so no '{mode}' mode: ignored"]
