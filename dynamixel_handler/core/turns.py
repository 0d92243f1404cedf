"""The whole turns a multi-turn servo loses when it boots, given back (ROS-free).

In extended and current-based position mode a servo counts turns only while it is powered: after a
reboot or a power cycle its position starts again within one turn of its Homing Offset. The turns
it had, judged from its last known position, go into the Homing Offset (one EEPROM write, torque
off for it as for every EEPROM write), so that the position it reports is the one before and every
tool reading it agrees. Used by the error clear (a reboot) and after a servo lost its power: its
adapter gone and back (``recovery.py``), or the servo silent and answering again.

A servo that moved more than half a turn while it was off cannot be told from one that lost turns:
the nearest whole number of turns is taken. A servo whose torque is still on did not boot and is
left alone, as is one whose ``servos`` block sets the Homing Offset (the block wins)."""
from __future__ import annotations

from ..control_table import Model
from .deferred import EEPROM_WRITE_INTERVAL_S, Deferred
from .servo_io import ServoIO

__all__ = ["lost_turns", "give_back_turns"]


def per_turn(model: Model) -> int:
    return int(round(360.0 / model.position_deg_per_pulse))


def _read(io: ServoIO, dxl_id: int, item: str, tries: int = 3) -> int | None:
    """The item, asked up to ``tries`` times (a servo just booted, a busy line)."""
    for _ in range(tries):
        value = io.read_item(dxl_id, item)
        if value is not None:
            return value
    return None


def lost_turns(model: Model, before: int, after: int) -> int:
    """Whole turns from ``after`` back to ``before`` [pulses] (nearest)."""
    return int(round((before - after) / per_turn(model)))


def give_back_turns(io: ServoIO, eeprom: Deferred, dxl_id: int, before: int, booted: bool = True) -> str:
    """The turns ``dxl_id`` lost since it was at ``before`` [pulses] written into its Homing Offset;
    the line to log ("" when it lost none). ``booted``: the caller knows it just booted (a reboot);
    otherwise a servo whose torque is on, or whose position is beyond one turn of its offset, did
    not boot and keeps its position."""
    model = io.table.model(dxl_id)
    after, offset = _read(io, dxl_id, "present_position"), _read(io, dxl_id, "homing_offset")
    if after is None or offset is None:
        return f"ID {dxl_id}: whole turns lost at boot not looked for: its position or Homing Offset did not answer"
    if not booted and (_read(io, dxl_id, "torque_enable") != 0 or abs(after - offset) > per_turn(model)):
        return ""
    turns = lost_turns(model, before, after)
    if not turns:
        return ""
    new = offset + turns * per_turn(model)
    lo, hi = model.value_range("homing_offset")
    if not lo <= new <= hi:
        return (f"ID {dxl_id}: {turns:+d} turns lost at boot not given back: Homing Offset {new} would be beyond "
                f"its range {lo}..{hi} (its position now is {after}, it was {before})")
    written = eeprom.write_eeprom(dxl_id, "homing_offset", new)
    if not written:
        return f"ID {dxl_id}: {turns:+d} turns lost at boot not given back: Homing Offset not written ({written.why})"
    if _read(io, dxl_id, "homing_offset") != new:  # held back: the last write of it is too recent (EEPROM wear)
        return (f"ID {dxl_id}: {turns:+d} whole turns lost at boot: its Homing Offset {offset} -> {new} is written "
                f"once its last write is {EEPROM_WRITE_INTERVAL_S:g} s old (EEPROM wear); until then its position "
                f"reads {after}, then as before ({before})")
    now = io.read_item(dxl_id, "present_position")
    return (f"ID {dxl_id}: {turns:+d} whole turns lost at boot given back through its Homing Offset "
            f"({offset} -> {new}): position {after} -> {now}, as before ({before})")
