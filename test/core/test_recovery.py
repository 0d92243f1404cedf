"""Recovery: what happens to a servo that stops answering (ping false, counted, removed), one that
answers again, and a device that vanishes and comes back (its servos set up by the real
``ServoSetup``); ``Reboots``: a reboot and its limit."""
from __future__ import annotations

import logging

import numpy as np

from dynamixel_handler.bus.result import Failure
from dynamixel_handler.control_table import OPERATING_MODES
from dynamixel_handler.core.deferred import Deferred
from dynamixel_handler.core.group_io import GroupIO
from dynamixel_handler.core.kept_settings import KeptSettings
from dynamixel_handler.core.reboots import Reboots
from dynamixel_handler.core.recovery import Recovery
from dynamixel_handler.core.servo_io import ServoIO
from dynamixel_handler.core.servo_setup import ServoSetup, SetupSettings
from dynamixel_handler.core.state import StepReport
from dynamixel_handler.core.watchdog import Watchdog, WatchdogSettings
from dynamixel_handler.settings import LoopSettings

from support.fake_bus import XM430, FakeBus, table_of


def recovery(servos, remove_after: int = 3, interval_s: float = 1.0):
    bus = FakeBus(servos)
    table = table_of(bus)
    lines: list[str] = []
    log = logging.getLogger(f"test_recovery_{id(bus)}")
    log.setLevel(logging.INFO)
    log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    io = ServoIO(bus, table, log)
    dog = Watchdog(table, log, io, GroupIO(bus, table, log), WatchdogSettings(100.0, 1, 500.0, True))
    removed: list[int] = []
    table.watch_removals(removed.append)  # a removal is an event the table tells its watchers
    settings = LoopSettings(no_response_auto_remove=remove_after, clear_error_interval_s=interval_s)
    work = Deferred(table, log, io)
    kept = KeptSettings(table, io, work, dog, (), lambda level, msg: log.log(level, msg))
    reboots = Reboots(bus, table, log, io, dog, kept, settings)
    setup = Counted(table, log, io, work, dog, kept, reboots, SetupSettings(torque_auto_enable=False))
    part = Recovery(bus, table, log, io, dog, settings, setup)
    return bus, table, part, lines, removed, setup.done


class Counted(ServoSetup):
    """The set-up of the node, and the IDs it set up, in order."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.done: list[int] = []

    def setup_servo(self, dxl_id: int, torque: bool | None = None) -> None:
        self.done.append(dxl_id)
        super().setup_servo(dxl_id, torque)


def loop(part: Recovery, table, answering: set[int]) -> None:
    """One loop's reads addressed every servo; those in ``answering`` answered."""
    addressed = np.ones(len(table), dtype=bool)
    answered = np.array([i in answering for i in table.ids])
    part.update_ping(addressed, answered)


def test_a_silent_servo_reads_ping_false_with_one_line_and_is_removed_after_the_count():
    _, table, part, lines, removed, _ = recovery({1: XM430, 2: XM430}, remove_after=3)
    loop(part, table, {1})
    assert list(table.ping) == [True, False] and list(table.no_response) == [0, 1]
    loop(part, table, {1})
    assert not removed and lines == ["ID 2: no response (ping false)"]
    loop(part, table, {1})
    assert removed == [2] and lines[-1].startswith("ID 2: no response 3 times in a row: removed")


def test_a_servo_that_answers_again_is_counted_from_zero_and_its_watchdog_armed_at_the_next_step():
    _, table, part, lines, removed, _ = recovery({1: XM430}, remove_after=0)
    for _ in range(5):
        loop(part, table, set())
    assert not removed and table.no_response[0] == 5  # 0: never removed
    loop(part, table, {1})
    assert table.ping[0] and table.no_response[0] == 0 and part.watchdog.to_arm == {1}


def test_a_reboot_waits_for_the_servo_restores_its_profiles_and_a_second_one_too_soon_is_refused():
    bus, table, recovering, lines, _, _ = recovery({1: XM430}, interval_s=60.0)
    part = recovering.setup.reboots
    table.set_value("operating_mode", 1, OPERATING_MODES["position"])
    table.set_value("profile_velocity", 1, 77)
    assert part.reboot(1)
    assert ("write", "profile_velocity", (1, 77)) in bus.item_writes()
    assert bus.of("reboot") == [("reboot", 1)] and bus.of("ping")
    assert not part.reboot(1)
    assert bus.of("reboot") == [("reboot", 1)]
    assert lines[-1].startswith("ID 1: reboot refused: the last one was")


def test_a_vanished_device_marks_every_servo_silent_without_counting_and_sets_them_up_once_back():
    bus, table, part, lines, removed, set_up = recovery({1: XM430, 2: XM430}, remove_after=1)
    part.watch_device()  # the device open at start-up
    bus.is_open, bus.can_reopen = False, False
    assert part.device_gone
    report = StepReport(loop=0)
    part.reconnect(report)
    assert part.device_lost and not table.ping.any() and "status" in report.groups
    loop(part, table, set())
    assert not removed and not table.no_response.any()  # the device is gone, not the servos
    bus.can_reopen, bus.silent = True, {2}
    part._next_reconnect = 0.0  # the next attempt is due (once a second)
    part.reconnect(StepReport(loop=1))
    assert not part.device_lost and part.reconnects == 1 and set_up == [1]
    assert "1 servo(s) [1] answer and are set up as at start-up" in lines[-1]
    # ID 2 answers later (a slow power-up, a busy host): set up as at start-up then, once
    assert not part.set_up_due
    bus.silent = set()
    loop(part, table, {1, 2})
    assert part.set_up_due
    part.set_up_returned()
    assert set_up == [1, 2] and lines[-1] == "ID 2: answers after the reconnect: set up as at start-up"
    loop(part, table, {1, 2})
    assert not part.set_up_due and set_up == [1, 2]


def test_a_refused_reboot_says_why_in_its_result():
    _, _, recovering, _, _, _ = recovery({1: XM430}, interval_s=60.0)
    part = recovering.setup.reboots
    assert part.reboot(1).failure is None
    refused = part.reboot(1)
    assert refused.value is False and refused.failure is Failure.HELD_BACK and refused.why.startswith("refused: the last one was")


def test_a_servo_back_after_losing_its_power_is_set_up_again_with_the_torque_it_had_and_one_that_kept_it_is_not():
    bus, table, part, lines, _, set_up = recovery({1: XM430, 2: XM430}, remove_after=0)
    for dxl_id in (1, 2):
        table.set_value("torque_enable", dxl_id, 1)
        table.set_value("profile_velocity", dxl_id, 77)
        bus.set(dxl_id, "torque_enable", 1)
        bus.set(dxl_id, "profile_velocity", 77)
    loop(part, table, set())                   # both go silent
    bus.set(1, "torque_enable", 0)             # 1 booted meanwhile: torque off, its RAM at the defaults
    bus.set(1, "profile_velocity", 0)
    loop(part, table, {1, 2})                  # both answer again
    assert part.back_due
    part.look_at_returned()
    assert set_up == [1] and not part.back_due  # 2 kept its torque: it did not boot
    assert "ID 1: answers again after a power loss (RAM at its defaults): set up again, torque on as it was" in lines
    assert ("write", "profile_velocity", (1, 77)) in bus.item_writes()  # its profile as before
    assert bus.get(1, "torque_enable") == 1    # on as it was, though torque_auto_enable is false here


def test_a_servo_back_that_kept_its_power_costs_one_read_and_is_left_as_it_is():
    bus, table, part, _, _, set_up = recovery({1: XM430}, remove_after=0)
    table.set_value("torque_enable", 1, 1)
    bus.set(1, "torque_enable", 1)
    loop(part, table, set())
    loop(part, table, {1})  # a read lost on a noisy line
    reads = len(bus.of("read"))
    part.look_at_returned()
    assert not part.back_due and set_up == [] and len(bus.of("read")) == reads + 1  # its torque, read once
def test_a_servo_back_whose_reads_get_no_answer_is_asked_again_at_the_next_step():
    bus, table, part, _, _, set_up = recovery({1: XM430}, remove_after=0)
    table.set_value("torque_enable", 1, 1)
    loop(part, table, set())
    bus.set(1, "torque_enable", 0)  # booted meanwhile
    loop(part, table, {1})
    bus.silent = {1}                # its reads lost on a busy line
    part.look_at_returned()
    assert part.back_due and set_up == []
    bus.silent = set()
    part.look_at_returned()
    assert not part.back_due and set_up == [1]
