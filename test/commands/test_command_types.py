"""``commands.command_types``: a command is a value queued as it came (any thread) and checked only
when the loop thread takes it; each message group's value reaches the commander's handler for it,
and a queued value cannot be changed by its sender afterwards."""
import dataclasses

import pytest

from dynamixel_handler.commands import Commander
from dynamixel_handler.commands.command_types import GROUPS, Control, Goal, Shortcut, Status
from dynamixel_handler.control_table import X

from support.servo_access import FakeAccess, attached, warnings_of

XM430, H54 = 1020, 54024


class QueuedAccess(FakeAccess):
    """Requests queued as the core's intake queues them, taken when the test says (``run``)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.queue: list = []

    def submit(self, request, what=""):
        self.queue.append(request)

    def run(self) -> None:
        queued, self.queue = self.queue, []
        for request in queued:
            FakeAccess.submit(self, request)


def _commander():
    access = QueuedAccess({1: XM430, 2: XM430, 3: H54})
    lines = warnings_of(access)
    return attached(Commander(access)), access, lines


def test_a_command_is_queued_as_a_value_and_checked_only_when_the_loop_takes_it():
    c, access, lines = _commander()
    ids, fields = [1, 9], {"position_deg": [0.0, 0.0]}
    c.goal(ids, fields)
    assert access.queue == [Goal([1, 9], fields, "goal")] and not access.goals and not lines
    ids.append(2)  # the sender's list changed after it was queued: the command is as it came
    access.run()
    assert access.goals == [{"goal_position": {1: 2048}}] and lines == ["goal: ID 9 is not handled: ignored"]
    queued = Goal([1], {"position_deg": [0.0]})
    with pytest.raises(dataclasses.FrozenInstanceError):
        queued.ids = [2]  # type: ignore[misc]


def test_each_message_group_goes_to_the_commanders_handler_for_it():
    c, access, _ = _commander()
    for group, kind in GROUPS.items():
        getattr(c, group)([1], {})
        assert type(access.queue[-1]) is kind, group
        assert kind in access.routes, group
    access.queue.clear()
    access.submit(Status([1, 2], {"torque": [False, True]}))
    access.run()
    assert ("torque_off", 1) in access.calls and ("torque_on", 2) in access.calls


def test_a_control_value_carries_its_family_and_a_shortcut_its_action():
    c, access, lines = _commander()
    c.control("X", "position_control", [1, 3], {"position_deg": [0.0, 0.0]})
    c.shortcut("TOFF", [2])
    control, shortcut = access.queue
    assert isinstance(control, Control) and control.family is X and control.what == "x position_control"
    assert shortcut == Shortcut("torque_off", [2], "shortcut TOFF")
    access.run()
    assert access.goals == [{"goal_position": {1: 2048}}] and ("torque_off", 2) in access.calls
    assert lines == ["x/position_control: ID 3 is H54-200-S500-R (series PRO), not X: ignored"]
