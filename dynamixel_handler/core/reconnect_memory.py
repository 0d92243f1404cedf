"""A reconnect puts back what the servo had, not the start values (ROS-free).

When the adapter vanishes, what the handler knows of each servo is kept (``remember``): the
profiles it last wrote or read, its mode, its goals, and every EEPROM item it has read. When the
device is back and the servo has been set up as at start-up (start values, the ``servos`` block),
``restore`` writes back the profiles and the mode the servo had (an item the ``servos`` block sets
keeps the block's value), says which goals of a velocity, current or PWM mode were not resumed
(the servo holds still until the next command: a motion is never restarted by a reconnect), and
names every EEPROM item that now differs from before (a servo replaced while unplugged, or changed
by another tool).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Callable

from .. import units
from ..control_table import KEPT_POSITION_MODES
from ..servo.table import ServoTable
from .servo_io import MODE, ServoIO

#: RAM items the start-up set-up writes its start values to: written back as they were
PROFILES = ("profile_acceleration", "profile_velocity")
#: a mode's own goal that the set-up's torque on sets to 0
OWN_GOALS = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}
#: EEPROM items not compared (the ID and the rate are how it was found again)
NOT_COMPARED = ("id", "baud_rate")

Say = Callable[[int, str], None]


@dataclass(frozen=True)
class Remembered:
    """What the handler knew of one servo when its device went."""

    mode: str | None
    profiles: dict[str, int] = field(default_factory=dict)
    goal: tuple[str, int] | None = None       #: a velocity / current / PWM goal that was not 0
    eeprom: dict[str, int] = field(default_factory=dict)
    #: the last present position [pulses] of a multi-turn servo (its turns are given back after a boot)
    position: int | None = None
    torque: int | None = None                  #: Torque Enable as last read


def remember(table: ServoTable, dxl_id: int) -> Remembered:
    """The servo's known state, from the table (no bus access: the device is gone)."""
    model = table.model(dxl_id)
    mode = model.mode_name(table.value(MODE, dxl_id))
    profiles = {item: v for item in PROFILES if (v := table.value(item, dxl_id)) is not None}
    own = OWN_GOALS.get(mode or "")
    value = table.value(own, dxl_id) if own is not None else None
    eeprom = {name: v for name, spec in model.items.items()
              if spec.eeprom and name not in NOT_COMPARED and (v := table.value(name, dxl_id)) is not None}
    position = table.value("present_position", dxl_id) if mode in KEPT_POSITION_MODES else None
    return Remembered(mode, profiles, (own, value) if own is not None and value else None, eeprom, position,
                      table.value("torque_enable", dxl_id))


def differences(io: ServoIO, dxl_id: int, before: Remembered, say: Say) -> None:
    """Once it answers again, before its set-up: one line naming the EEPROM items that differ (each
    read anew, so that the set-up sees the mode the servo has now)."""
    changed = _changed_eeprom(io, dxl_id, before)
    if changed:
        say(logging.WARNING, f"ID {dxl_id} ({io.table.model(dxl_id).name}): EEPROM differs from before the device "
            f"went (replaced while unplugged, or changed by another tool?): {', '.join(changed)}")


def restore(io: ServoIO, dxl_id: int, before: Remembered, file_sets: Callable[[str], bool], say: Say,
            put_back: Callable[[int, str], None]) -> None:
    """After the reconnect's set-up: the mode it had and its profiles (unless the servos block sets
    them; the block's RAM items again after a mode change), one line for a goal not resumed."""
    model = io.table.model(dxl_id)
    if before.mode is not None and not file_sets(MODE) and io.mode(dxl_id) != before.mode \
            and before.mode in model.mode_values:
        _mode_back(io, dxl_id, before.mode, say, put_back)
    back = [f"{item} {value}" for item, value in before.profiles.items()
            if not file_sets(item) and model.has(item) and io.write_item(dxl_id, item, value)]
    if back:
        say(logging.INFO, f"ID {dxl_id}: as before the device went: {', '.join(back)} (not the start values)")
    if before.goal is not None:
        item, value = before.goal
        shown = float(units.pulse_to_unit([model], item, [value])[0])
        say(logging.WARNING, f"ID {dxl_id}: {item} {shown:g} not resumed after the reconnect: the servo holds still "
            "(goal 0) until the next command")


def _mode_back(io: ServoIO, dxl_id: int, mode: str, say: Say, put_back: Callable[[int, str], None]) -> None:
    torque = io.torque_off_for_eeprom(dxl_id)
    written = io.write_item(dxl_id, MODE, io.table.model(dxl_id).mode_values[mode])
    if written:
        put_back(dxl_id, f"the mode change to {mode}")
    if torque:
        io.torque_on(dxl_id)
    say(logging.WARNING if not written else logging.INFO,
        f"ID {dxl_id}: mode {mode} as before the device went" + ("" if written else f" not set: {written.why}"))


def _changed_eeprom(io: ServoIO, dxl_id: int, before: Remembered) -> list[str]:
    out = []
    for item, value in before.eeprom.items():
        now = io.read_item(dxl_id, item)
        if now is not None and now != value:
            out.append(f"{item} {value} -> {now}")
    return out


def booted(io: ServoIO, dxl_id: int, before: Remembered) -> bool | None:
    """Whether a servo that went silent and answers again lost its power meanwhile: its torque was
    on and is off with no hardware error to explain it (a shutdown turns torque off, a power loss
    clears the error), or a profile the handler had written reads 0 (RAM at its defaults); None when
    a read that would tell got no answer (ask again later)."""
    torque = io.read_item(dxl_id, "torque_enable")
    profiles = [io.read_item(dxl_id, item) for item, value in before.profiles.items() if value]
    if torque is None or None in profiles:
        return None
    if 0 in profiles:
        return True
    if not (before.torque and torque == 0):
        return False
    behaviour = io.table.model(dxl_id).family.behaviour
    return not behaviour.is_error(io.read_item(dxl_id, behaviour.status_error_item or behaviour.error_item))


__all__ = ["Remembered", "booted", "differences", "remember", "restore"]
