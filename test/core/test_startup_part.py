"""Startup, built on its own over the real parts it calls (``support.parts``, a fake bus): which IDs
the scan asks, which servos are kept and which skipped with which line, the set-up every servo gets
(also when added later), a hardware error found at start-up, an expected count not met, a stop
asked for during the start-up, and the add_id / remove_id requests of one loop. (test_startup.py
asks the same through the Handler front.)"""
from __future__ import annotations

import logging

import pytest

from dynamixel_handler.core.startup import UNKNOWN_MODEL_HELP, Startup
from dynamixel_handler.errors import Interrupted, StartupError
from dynamixel_handler.settings import Settings

from support.fake_bus import H54, XM430, FakeBus
from support.parts import Parts, build, lines_of


def startup(servos, name: str, **changes) -> tuple[FakeBus, Parts, Startup, list[str]]:
    bus = FakeBus(servos)
    log, lines = lines_of(f"test_startup_part.{name}", logging.INFO)
    parts = build(bus, Settings().but(**{"scan__max_id": 6, **changes}), log)
    return bus, parts, parts.startup, lines


def test_the_scan_asks_the_id_range_keeps_the_used_series_and_says_what_it_skipped():
    bus, parts, part, lines = startup({1: XM430, 2: XM430, 5: H54}, "kept", scan__min_id=1)
    part.start()
    assert bus.of("scan") == [("scan", (1, 2, 3, 4, 5, 6))]
    assert list(parts.table.ids) == [1, 2]
    assert "scan 1/1 of IDs 1..6 on fake at 57600 bps: 3 servo(s) [1, 2, 5]" in lines
    assert "ID 5: H54-200-S500-R is series PRO, which init/used_servo_series does not enable: skipped" in lines
    assert "ID 1: XM430-W350 (model 1020, series X) handled" in lines


def test_every_servo_is_set_up_return_delay_profiles_then_torque_on_without_a_jump():
    bus, parts, part, _ = startup({1: XM430}, "set up", start__return_delay_time=20.0)
    bus.set(1, "operating_mode", 3)
    bus.set(1, "present_position", 5000)
    bus.set(1, "max_position_limit", 4095)
    part.start()
    assert [w[1:] for w in bus.item_writes()] == [
        ("return_delay_time", (1, 10)),                # 20 us, 2 us a unit
        ("profile_acceleration", (1, bus.get(1, "profile_acceleration"))),
        ("profile_velocity", (1, bus.get(1, "profile_velocity"))),
        ("goal_position", (1, 4095)),                  # the present position, within the limits
        ("torque_enable", (1, 1))]
    assert parts.watchdog.to_arm == {1}  # armed when the loop starts, not servo by servo now


def test_without_torque_auto_enable_the_torque_is_left_off():
    bus, _, part, _ = startup({1: XM430}, "no torque", scan__torque_auto_enable=False)
    part.start()
    assert "torque_enable" not in [w[1] for w in bus.item_writes()]


def test_a_hardware_error_found_at_start_up_is_cleared_by_a_reboot_with_a_warning_unless_told_not_to():
    bus, _, part, lines = startup({1: XM430}, "error")
    bus.set(1, "hardware_error_status", 0x20)
    part.start()
    assert bus.of("reboot") == [("reboot", 1)]
    assert "ID 1: hardware error 0x20 at start-up: clearing it by reboot" in lines
    bus, _, part, _ = startup({1: XM430}, "error kept", scan__hardware_error_auto_clean=False)
    bus.set(1, "hardware_error_status", 0x20)
    part.start()
    assert bus.of("reboot") == []


def test_fewer_servos_than_expected_end_the_start_up_after_the_retries_unless_debug():
    bus, _, part, _ = startup({1: XM430}, "expected", scan__expected=2, scan__retry_times=2)
    with pytest.raises(StartupError, match=r"found 1 servo\(s\) on fake at 57600 bps, expected 2"):
        part.start()
    assert len(bus.of("scan")) == 3
    bus, parts, part, lines = startup({1: XM430}, "debug", scan__expected=2, loop__debug=True)
    part.start()
    assert list(parts.table.ids) == [1] and any(line.endswith("(debug: running on)") for line in lines)


def test_no_servo_of_a_used_series_ends_the_start_up_naming_the_parameter():
    _, _, part, _ = startup({5: H54}, "no series")
    with pytest.raises(StartupError, match=r"no servo of the used series \(X\) among IDs \[5\]: enable their series "
                                           r"in init/used_servo_series"):
        part.start()


def test_an_unknown_model_number_is_skipped_with_what_the_user_can_do():
    class UnknownAtOne(FakeBus):
        def scan(self, ids, broadcast=None):
            return {i: (9999 if i == 1 else n) for i, n in super().scan(ids, broadcast).items()}

    log, lines = lines_of("test_startup_part.unknown", logging.INFO)
    parts = build(UnknownAtOne({1: XM430, 2: XM430}), Settings().but(scan__max_id=6), log)
    parts.startup.start()
    assert list(parts.table.ids) == [2]
    assert f"ID 1: unknown model number 9999, not handled: {UNKNOWN_MODEL_HELP}" in lines


def test_a_stop_asked_for_during_the_start_up_ends_it_before_the_next_servo():
    bus, parts, part, _ = startup({1: XM430}, "stop")
    parts.stopping[0] = True
    with pytest.raises(Interrupted, match="during the scan"):
        part.start()
    assert bus.of("scan") == []


def test_add_id_sets_an_answering_servo_up_and_says_why_another_is_not_added_once_a_second():
    bus, parts, part, lines = startup({1: XM430, 2: XM430, 5: H54}, "add", scan__max_id=1)
    part.start()
    bus.calls.clear()
    assert part.add_id(2) and list(parts.table.ids) == [1, 2]
    assert "ID 2: XM430-W350 added" in lines and ("write", "torque_enable", (2, 1)) in bus.item_writes()
    assert not part.add_id(3) and not part.add_id(3)
    assert lines.count("ID 3: no answer to ping, not added") == 1
    assert not part.add_id(5)
    assert lines[-1] == "ID 5: H54-200-S500-R is series PRO, not enabled in init/used_servo_series"


def test_add_and_remove_asked_many_times_in_one_loop_make_at_most_one_change_each():
    bus, parts, part, lines = startup({1: XM430, 2: XM430}, "membership", scan__max_id=1)
    part.start()
    for _ in range(5):
        part.want_handled(2, True)
        part.want_handled(2, False)
    part.want_handled(2, True)
    part.want_handled(1, False)
    bus.calls.clear()
    part.apply_membership()
    assert list(parts.table.ids) == [2] and bus.of("ping") == [("ping", 2)]
    assert part.membership is None
    assert "ID 1: removed from the handled servos" in lines  # the table told the parts that watch it
