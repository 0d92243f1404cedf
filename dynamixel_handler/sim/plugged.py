"""The servos plugged into the virtual bus: making one of a model number (Protocol 2.0 or 1.0),
pairing the two IDs of a dual servo, putting one at a baud rate, and the ``--state`` file that
keeps their EEPROM across restarts of the bus (IDs, baud rates, limits; a shared ID stays shared).
"""

from __future__ import annotations

import json
import os
from typing import Callable, Iterable

from dynamixel_handler.control_table import model_by_number

from .protocol1 import PROTOCOL1_MODELS
from .servo import VirtualServo

AnyServo = VirtualServo
"""A servo of the bus, of any family (one engine: ``VirtualServo``)."""


def new_servo(model_number: int, servo_id: int, clock: Callable[[], float]) -> AnyServo:
    """A factory-fresh servo of the model at ``servo_id`` (the model numbers of the Protocol 1.0
    families and of the others do not overlap)."""
    model = PROTOCOL1_MODELS.get(model_number) or model_by_number(model_number)
    return VirtualServo(model, servo_id, clock)


def pair(servo: AnyServo, servos: Iterable[AnyServo]) -> None:
    """A dual servo (2XL430, 2XC430) is two IDs sharing one Baud Rate: each one added is
    paired with the first unpaired one of its model, in the order they were added."""
    if not servo.model.name.startswith("2X"):
        return
    for other in servos:
        if other.model.number == servo.model.number and other.partner is None:
            servo.partner, other.partner = other, servo
            servo.write("baud_rate", other.read("baud_rate"))
            return


def set_bps(servo: AnyServo, bps: int) -> None:
    """Put the servo at ``bps`` (its Baud Rate register); a rate it cannot run at is an error."""
    values = {rate: v for v, rate in servo.baud_rates.items()}
    if bps not in values:
        raise ValueError(f"{servo.model.name} cannot run at {bps} bps "
                         f"(it can: {', '.join(str(b) for b in sorted(values))})")
    servo.write("baud_rate", values[bps])


def state_of(servos: Iterable[AnyServo]) -> dict:
    """The state file's content (every servo's EEPROM, by ID); marks their EEPROM saved."""
    servos = sorted(servos, key=lambda s: s.id)
    data = {"servos": [s.state() for s in servos]}
    for s in servos:
        s.eeprom_changed = False
    return data


def write_state(path: str, data: dict) -> None:
    """Write a state file atomically."""
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
    os.replace(tmp, path)


def read_state(path: str, clock: Callable[[], float]) -> list[AnyServo]:
    """The servos a state file lists, powered up with their saved EEPROM, dual servos paired."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    servos: list[AnyServo] = []
    for entry in data["servos"]:
        servo = new_servo(int(entry["model"]), 1, clock)
        servo.load_state(entry, clock())
        pair(servo, servos)
        servos.append(servo)
    return servos
