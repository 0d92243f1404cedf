"""Protocol 1.0 servos for the set-up tool's scan: ping an ID and read its model number and
firmware through the bus (the Protocol 1.0 framer, ``protocol.protocol1``), and name the model.
The handler drives Protocol 2.0 servos only; a Protocol 1.0 servo found here is reported with what
it is and how to bring it to Protocol 2.0 where it can. A broadcast ping gets no status in
Protocol 1.0, so every ID is pinged on its own.
"""
from __future__ import annotations

from ..bus import DynamixelBus, Failure
from ..bus.ops import Ping
from ..protocol import protocol1 as p1

__all__ = ["ping1", "model_name1", "SWITCH_TO_2", "statuses1", "error_text1"]


#: Protocol 1.0 model numbers (ROBOTIS e-Manual pages of each model, "Model Number")
MODELS_1: dict[int, str] = {
    12: "AX-12A", 18: "AX-18A", 300: "AX-12W", 24: "RX-24F", 28: "RX-28", 64: "RX-64", 107: "EX-106+",
    360: "MX-12W", 29: "MX-28", 310: "MX-64", 320: "MX-106",
}
#: MX models whose Protocol 2.0 firmware exists (then model 30, 311, 321: "MX-28(2.0)" ...)
SWITCH_TO_2: dict[int, str] = {
    29: "MX-28", 310: "MX-64", 320: "MX-106",
}


def model_name1(number: int) -> str:
    return MODELS_1.get(number, f"model {number}")


def error_text1(error: int) -> str:
    """A Protocol 1.0 status error byte in words ("no error" when 0)."""
    return p1.error_text(error)


def statuses1(data: bytes) -> list[tuple[int, int, bytes]]:
    """Every valid status packet in ``data`` as (ID, error byte, parameters); noise and packets
    with a wrong checksum are skipped."""
    return [(s.dxl_id, s.error, s.params) for s in p1.statuses(data)]


def ping1(bus: DynamixelBus, dxl_id: int) -> tuple[int, int] | None:
    """(model number, firmware) of a Protocol 1.0 servo at ``dxl_id``; None when none answers,
    (0, 0) when it answers the ping but not the read of its model number (Status Return Level 0)."""
    got = bus.execute(Ping(dxl_id, retries=0, protocol=1))
    if got.value is not None:
        return got.value, bus.firmware_versions.get(dxl_id, 0)
    return (0, 0) if got.failure is Failure.ANSWERS_PING_ONLY else None
