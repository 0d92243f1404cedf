"""Modes of a Protocol 1.0 model (AX, RX, DX, EX, MX (1.0)): it has no Operating Mode register; its
Angle Limits select the mode (ROBOTIS e-Manual, "CW/CCW Angle Limit"): both 0 is Wheel Mode
(``velocity``), both 4095 on MX multi-turn (``ex_position``), anything else Joint Mode
(``position``); on MX-64/106 Torque Control Mode Enable (RAM) 1 is ``current``.

``set-mode`` writes those registers. Joint Mode gets the model's factory limits (the full range:
0 .. 1023 on AX/RX/DX, 0 .. 4095 on MX/EX) unless it is in Joint Mode already; the limits it had
are said (and kept in the JSON document, ``limits_were``) with the two ``set`` lines that bring
them back. Also what ``info`` says about any servo beside its items: protocol, firmware, mode,
torque and errors (a Protocol 1.0 servo's from the error byte of its status packets)."""
from __future__ import annotations

from typing import Any, Mapping

from ..control_table._protocol1 import MULTI_TURN_LIMIT
from ..protocol.framers import FRAMERS
from .context import Context
from .errors import BadArguments
from .items import show_value
from .protocol1 import mode1
from .safety import JOURNAL, TorqueOn, held
from .scan import _errors
from .servo import Servo

__all__ = ["summary", "state_line", "set_mode1"]

_LIMITS = ("min_position_limit", "max_position_limit")
_WHAT = {"position": "Joint Mode", "velocity": "Wheel Mode", "ex_position": "multi-turn",
         "current": "torque control"}


def summary(servo: Servo, values: Mapping[str, int]) -> dict[str, Any]:
    """Protocol, firmware, mode, torque and errors of a servo whose items ``values`` holds (raw)."""
    model = servo.model
    if model.has("operating_mode") and "operating_mode" in values:
        mode = model.mode_name(values["operating_mode"])
    elif servo.modes_by_limits and all(n in values for n in _LIMITS):
        mode = mode1(model, values[_LIMITS[0]], values[_LIMITS[1]], values.get("torque_control_mode_enable", 0))
    else:
        mode = None
    if FRAMERS[servo.protocol].state_in_error_byte:
        errors = servo.status_errors()
    else:
        errors = _errors(values.get("hardware_error_status", 0))
    firmware = values.get("firmware_version", servo.bus.firmware_versions.get(servo.dxl_id))
    torque = values.get("torque_enable")
    return {"protocol": f"{servo.protocol}.0", "firmware": firmware, "mode": mode,
            "torque": None if torque is None else ("on" if torque == 1 else "off"), "errors": errors}


def state_line(state: Mapping[str, Any]) -> str:
    """``protocol 1.0, firmware 24, mode position, torque on, errors input_voltage``."""
    shown = [f"{key} {'-' if state[key] is None else state[key]}" for key in ("protocol", "firmware", "mode", "torque")]
    return ", ".join(shown) + f", errors {', '.join(state['errors']) or 'none'}"


def _targets(servo: Servo, mode: str, limits: tuple[int, int]) -> dict[str, int]:
    """The registers (name -> raw) that put ``servo`` into ``mode`` from Angle Limits ``limits``."""
    model = servo.model
    new: dict[str, int] = {}
    if model.has("torque_control_mode_enable"):
        new["torque_control_mode_enable"] = 1 if mode == "current" else 0
    if mode == "velocity":
        new.update(min_position_limit=0, max_position_limit=0)
    elif mode == "ex_position":
        new.update(min_position_limit=MULTI_TURN_LIMIT, max_position_limit=MULTI_TURN_LIMIT)
    elif mode == "position" and mode1(model, *limits) != "position":
        new.update(min_position_limit=model.factory.get(_LIMITS[0], 0),
                   max_position_limit=model.factory.get(_LIMITS[1], model.position_max_pulse))
    return new


def _mode_of(servo: Servo, text: str) -> str:
    modes = servo.model.mode_values
    key = text.strip().lower()
    if key not in modes:
        raise BadArguments(f"{servo.who}: {servo.model.name} has no mode '{text[:40]}' (one of {', '.join(modes)}; "
                           "a Protocol 1.0 servo's Angle Limits select it)")
    return key


def _limits_text(servo: Servo, limits: tuple[int, int]) -> str:
    item = servo.item(_LIMITS[0])
    return f"{show_value(servo.model, item, limits[0])} .. {show_value(servo.model, item, limits[1])}"


def _write(ctx: Context, servo: Servo, new: dict[str, int], torque: bool) -> None:
    """The registers of the new mode as one critical step: torque off (if on), the goal at rest,
    each register written and read back, torque back on without a jump."""
    with held():
        entry = JOURNAL.touch(servo.dxl_id, servo.model.name, ctx.bus.baudrate, "on" if torque else "off")
        if torque:
            servo.write("torque_enable", 0)
            entry.torque = "off (it was on; the load is not held)"
        if servo.model.has("goal_velocity"):
            if new.get("max_position_limit") == 0:
                servo.write("goal_velocity", 0)  # Wheel Mode turns at Moving Speed: at rest first
            elif (speed := servo.read("goal_velocity")) < 0:
                servo.write("goal_velocity", -speed)  # out of Wheel Mode: its direction bit means nothing there
        if servo.model.has("goal_current") and "torque_control_mode_enable" in new:
            servo.write("goal_current", 0)
        for name, raw in new.items():
            servo.set_checked(name, raw)
        if torque:
            servo.torque_on_in_place()
            entry.torque = "on (as before)"


def _refuse_torque(ctx: Context, servo: Servo, was: str, mode: str) -> bool:
    """Whether its torque is on (it goes off for the switch); TorqueOn unless ``--torque-off``."""
    torque = servo.model.has("torque_enable") and servo.torque_on()
    if torque and not ctx.torque_off:
        raise TorqueOn(f"{servo.who}: torque is on and switching it from {was} to {mode} ({_WHAT[mode]}) is done with "
                       "torque off, which lets go of the load it holds: refused, nothing written (give --torque-off to "
                       "turn it off, switch, set the goal to where it is and turn it back on)")
    return torque


def _said(ctx: Context, servo: Servo, modes: tuple[str, str], limits: tuple[int, int], torque: bool) -> list[int]:
    """What the switch did, and how to have the Joint Mode limits back; the limits now."""
    was, mode = modes
    now = (servo.read(_LIMITS[0]), servo.read(_LIMITS[1]))
    ctx.out.say(f"{servo.who} mode {was} -> {mode} ({_WHAT[mode]}): angle limits {_limits_text(servo, limits)} -> "
                f"{_limits_text(servo, now)}, read back" + ("; torque off and on again (goal := present)" if torque else ""))
    factory = (servo.model.factory.get(_LIMITS[0], 0), servo.model.factory.get(_LIMITS[1]))
    if was == "position" and now != limits and limits != factory:
        ctx.out.say(f"its Joint Mode limits were {limits[0]} .. {limits[1]} (raw): `set-mode {servo.dxl_id} position` "
                    f"writes the factory {factory[0]} .. {factory[1]}; then `set {servo.dxl_id} min_position_limit "
                    f"{limits[0]} --raw` and `set {servo.dxl_id} max_position_limit {limits[1]} --raw` bring these back")
    elif mode == "position":
        ctx.out.say(f"angle limits are the {servo.model.name}'s factory ones; other Joint Mode limits: "
                    f"set {servo.dxl_id} min_position_limit / max_position_limit")
    return list(now)


def set_mode1(ctx: Context, servo: Servo, text: str) -> None:
    """``set-mode ID MODE`` on a Protocol 1.0 model: the Angle Limits (and Torque Control Mode
    Enable) written, with torque off if it was on (``--torque-off``), read back."""
    mode = _mode_of(servo, text)
    was = servo.mode() or "position"
    limits = (servo.read(_LIMITS[0]), servo.read(_LIMITS[1]))
    doc: dict[str, Any] = {"id": servo.dxl_id, "mode": mode, "was": was, "limits_were": list(limits)}
    if was == mode:
        ctx.out.say(f"{servo.who} is in {mode} mode already ({_WHAT[mode]}, angle limits {_limits_text(servo, limits)}): "
                    "nothing written")
        ctx.out.document.update(doc, written=False)
        return
    new = {k: v for k, v in _targets(servo, mode, limits).items() if servo.read(k) != v}
    torque = _refuse_torque(ctx, servo, was, mode)
    if any(servo.item(n).eeprom for n in new):
        ctx.confirm(f"{servo.who}: switch from {was} to {mode} ({_WHAT[mode]}) by writing "
                    f"{', '.join(f'{n} = {new[n]}' for n in new)} (EEPROM)?"
                    + (" Its torque is on: it goes off for the switch and back on with the goal where it is."
                       if torque else ""))
    _write(ctx, servo, new, torque)
    ctx.out.document.update(doc, limits=_said(ctx, servo, (was, mode), limits, torque), written=True)
