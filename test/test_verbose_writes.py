"""verbose/callback and verbose/write_{goal,limit,extra}: the command side's log lines, which the
typed settings (``settings.logs``) switch on and off, on an in-process Handler on a virtual bus."""
from __future__ import annotations

import logging

import pytest

from dynamixel_handler.commands import Commander

from support.handler_bench import capture_log, handler_on_virtual_bus
from support.servo_access import attached

XM430 = 1020
FLAGS = ("verbose/callback", "verbose/write_goal", "verbose/write_limit", "verbose/write_extra")


def _lines(on: bool) -> list[str]:
    with handler_on_virtual_bus({1: XM430}, {flag: on for flag in FLAGS}) as (_sim, handler):
        lines = capture_log(handler, f"verbose_writes.{on}")
        logging.getLogger(f"verbose_writes.{on}").setLevel(logging.INFO)
        commander = attached(Commander(handler))
        commander.goal([1], {"position_deg": [10.0]})
        commander.limit([1], {"velocity_limit_deg_s": [120.0]})
        commander.extra([1], {"return_delay_time_us": [2.0]})
        for _ in range(3):
            handler.step()
    return lines


@pytest.mark.parametrize("on", [True, False])
def test_the_write_log_lines_follow_their_parameters(on):
    lines = _lines(on)
    wanted = {
        "command accepted: goal": any(line.startswith("command accepted: goal") for line in lines),
        "pending": any(line.startswith("goal: pending") for line in lines),
        "limits written": any("ID 1 limits written" in line for line in lines),
        "extra": any("ID 1 extra fields handled: return_delay_time_us" in line for line in lines),
    }
    assert wanted == dict.fromkeys(wanted, on), lines
