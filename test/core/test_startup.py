"""Startup: the scan, which servos are kept, the set-up each gets, an expected count not met,
a stop during the scan, add_id and the add/remove requests of one loop (on a fake bus)."""
from __future__ import annotations

import logging

import pytest

from dynamixel_handler.config import defaults, validate
from dynamixel_handler.core.handler import Handler
from dynamixel_handler.errors import Interrupted, StartupError

from support.fake_bus import H54, XM430, FakeBus
from support.queued import Asker, Membership

LOG = logging.getLogger("test_startup")


def handler(servos, **params) -> tuple[FakeBus, Handler]:
    bus = FakeBus(servos)
    return bus, Handler(bus, validate({**defaults(), "init/servo_auto_search.max_id": 6, **params}), LOG)


def test_the_servos_of_the_used_series_are_kept_and_each_is_set_up_with_torque_on():
    bus, h = handler({1: XM430, 2: XM430, 5: H54})  # Pro not enabled: skipped
    bus.set(1, "return_delay_time", 250)
    bus.set(1, "operating_mode", 3)  # position
    bus.set(1, "present_position", 5000)
    bus.set(1, "max_position_limit", 4095)
    h.start()
    assert h.handled_ids == [1, 2]
    assert bus.of("scan") == [("scan", tuple(range(0, 7)))]
    writes = [w[1:] for w in bus.item_writes() if w[2][0] == 1]
    assert [item for item, _ in writes] == ["return_delay_time", "profile_acceleration", "profile_velocity",
                                            "goal_position", "torque_enable"]
    assert writes[0] == ("return_delay_time", (1, 0)) and writes[-2:] == [("goal_position", (1, 4095)),
                                                                          ("torque_enable", (1, 1))]
    assert h.watchdog.to_arm == {1, 2}  # armed when the loop starts, not servo by servo now


def test_fewer_servos_than_expected_end_the_start_up_unless_debug():
    _, h = handler({1: XM430}, **{"init/expected_servo_num": 2, "init/servo_auto_search.retry_times": 2})
    with pytest.raises(StartupError, match="expected 2"):
        h.start()
    bus, h = handler({1: XM430}, **{"init/expected_servo_num": 2, "debug": True})
    h.start()
    assert h.handled_ids == [1]


def test_a_stop_asked_for_during_the_scan_ends_the_start_up():
    bus = FakeBus({1: XM430})
    h = Handler(bus, validate({**defaults(), "init/servo_auto_search.max_id": 6}), LOG, interrupted=lambda: True)
    with pytest.raises(Interrupted):
        h.start()


def test_add_and_remove_asked_many_times_in_one_loop_make_at_most_one_change():
    bus, h = handler({1: XM430, 2: XM430}, **{"init/servo_auto_search.max_id": 1})
    h.start()
    assert h.handled_ids == [1]
    h.attach(Asker(h.core))
    for _ in range(5):
        h.submit(Membership(2, True))
        h.submit(Membership(2, False))
    h.submit(Membership(2, True))
    bus.calls.clear()
    h.step()
    assert h.handled_ids == [1, 2] and bus.of("ping") == [("ping", 2)]
    bus.silent.add(3)
    assert not h.core.add_servo(3)


def test_an_unknown_model_is_named_with_what_the_user_can_do(caplog):
    """Enabling a series cannot help a model number the control table does not know: the lines say
    where the known models are listed and how to report the number."""
    class UnknownAtOne(FakeBus):
        """ID 1 answers with a model number no table knows."""

        def scan(self, ids, broadcast=None):
            return {i: (9999 if i == 1 else n) for i, n in super().scan(ids, broadcast).items()}

    def handler(servos):
        return None, Handler(UnknownAtOne(servos), validate({**defaults(), "init/servo_auto_search.max_id": 6}), LOG)

    _, h = handler({1: XM430})
    with pytest.raises(StartupError, match=r"model numbers \[9999\]\): this version does not know that model") as err:
        h.start()
    assert "used_servo_series" not in str(err.value) and "docs/models.md" in str(err.value)
    _, h = handler({1: XM430, 2: XM430})
    with caplog.at_level(logging.WARNING, logger="test_startup"):
        h.start()
    assert h.handled_ids == [2]
    assert any("ID 1: unknown model number 9999, not handled: this version does not know" in r.getMessage()
               and "dynamixel_handler_setup scan" in r.getMessage() for r in caplog.records)
