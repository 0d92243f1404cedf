"""Typed settings (``settings.py``) built from the parameters (``config.settings_of``): the
defaults of the dataclasses are the parameters' defaults, and each parameter lands in its field."""
from __future__ import annotations

import pytest

from dynamixel_handler.config import SCHEMA, defaults, settings_of, validate
from dynamixel_handler.settings import BusSettings, ScanSettings, Settings


def test_the_dataclass_defaults_are_the_parameter_defaults():
    assert settings_of(defaults()) == Settings()
    assert validate(defaults()).settings == Settings()


def _changed(value):
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 3
    return value + "x"


def test_every_read_parameter_feeds_a_field():
    """A parameter changed from its default changes the settings (unless the core never reads it:
    the OpenCR IMU, the ROS-side ones and the joint map, which ros/ reads by name)."""
    ros_side = ("option/imu_opencr.", "joint_state.", "diagnostics.", "no_use_command_line",
                "init/dummy_servo_series", "init/dummy_servo_list")
    base = settings_of(defaults())
    unread = []
    for p in SCHEMA:
        if p.name.startswith(ros_side) or isinstance(p.default, list):
            continue
        changed = _changed(p.default)
        if settings_of({**defaults(), p.name: changed}) == base:
            unread.append(p.name)
    assert unread == []


def test_values_land_in_their_fields():
    s = validate({**defaults(), "device_name": "/dev/ttyACM3", "baudrate": 1000000, "init/servo_auto_search.min_id": 3,
                  "init/servo_auto_search.max_id": 7, "init/used_servo_series.P": True, "pub_ratio/extra.static_items": 5,
                  "pub_ratio/present.current": 0, "verbose/read_goal.raw": True, "verbose/write_extra": True,
                  "init/dummy_servo_list": [4, 300, 5], "init/dummy_servo_series": ["p"],
                  "mode_change_interval_sec": 2}).settings
    assert s.bus == BusSettings(device="/dev/ttyACM3", baudrate=1000000)
    assert (s.scan.min_id, s.scan.max_id, s.scan.used_series) == (3, 7, ("X", "P"))
    assert (s.scan.dummy_ids, s.scan.dummy_series) == ((4, 5), ("P", "P"))
    assert s.ratios.groups["extra_static"] == 5 and s.ratios.present["current"] == 0
    assert s.logs.reads_raw == {"goal"} and s.logs.writes == {"extra"} and s.logs.reads_err == set()
    assert s.loop.mode_change_interval_s == 2.0 and isinstance(s.loop.mode_change_interval_s, float)
    with pytest.raises(TypeError):
        s.ratios.groups["goal"] = 1  # type: ignore[index]  # replaced as a whole, never changed in place


def test_but_changes_fields_of_parts_and_keeps_the_rest():
    s = Settings(scan=ScanSettings(min_id=1, max_id=4))
    t = s.but(scan__torque_auto_enable=False, loop__rate_hz=50)
    assert (t.scan.min_id, t.scan.max_id, t.scan.torque_auto_enable, t.loop.rate_hz) == (1, 4, False, 50)
    assert s.scan.torque_auto_enable is True and s.loop.rate_hz == 100  # the original is untouched
    with pytest.raises(TypeError):
        s.but(rate_hz=50)
    with pytest.raises(TypeError):
        s.but(scan__no_such_field=1)
