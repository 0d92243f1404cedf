"""Protocol 1.0 on the bus's line, for the scan only: ping an ID and read its model number and
firmware. The handler drives Protocol 2.0 servos only; a Protocol 1.0 servo found here is
reported with what it is and how to bring it to Protocol 2.0 where it can.

Packets (ROBOTIS e-Manual, "DYNAMIXEL Protocol 1.0"): ``FF FF ID LEN INST PARAMS... CHECKSUM``,
checksum = ~(ID + LEN + INST + PARAMS) & 0xFF; PING 0x01, READ 0x02; the status is
``FF FF ID LEN ERROR PARAMS... CHECKSUM``. Model Number is at address 0 (2 bytes) and Firmware
Version at 2 in every Protocol 1.0 control table. A broadcast ping gets no status in Protocol 1.0,
so every ID is pinged on its own.
"""
from __future__ import annotations

import time

import serial

from ..bus import DynamixelBus

__all__ = ["ping1", "model_name1", "SWITCH_TO_2", "statuses1", "error_text1"]

PING, READ = 0x01, 0x02

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


def _packet(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
    body = bytes([dxl_id, len(params) + 2, instruction]) + params
    return b"\xff\xff" + body + bytes([~sum(body) & 0xFF])


#: the status error byte's bits (e-Manual, Protocol 1.0 "Status Packet")
ERROR_BITS1 = ("input voltage", "angle limit", "overheating", "range", "checksum", "overload", "instruction")


def error_text1(error: int) -> str:
    """A Protocol 1.0 status error byte in words ("no error" when 0)."""
    named = [name for bit, name in enumerate(ERROR_BITS1) if error >> bit & 1]
    return ", ".join(named) + f" error (0x{error:02X})" if named else "no error"


def statuses1(data: bytes) -> list[tuple[int, int, bytes]]:
    """Every valid status packet in ``data`` as (ID, error byte, parameters); noise and packets
    with a wrong checksum are skipped."""
    found = []
    start = data.find(b"\xff\xff")
    while start >= 0 and start + 6 <= len(data):
        sid, length = data[start + 2], data[start + 3]
        end = start + 4 + length
        if length >= 2 and end <= len(data) and (~sum(data[start + 2:end - 1]) & 0xFF) == data[end - 1]:
            found.append((sid, data[start + 4], bytes(data[start + 5:end - 1])))
            start = data.find(b"\xff\xff", end)
            continue
        start = data.find(b"\xff\xff", start + 1)
    return found


def _status(data: bytes, dxl_id: int) -> bytes | None:
    """The parameters of the first valid status of ``dxl_id`` in ``data`` (None if none)."""
    return next((params for sid, _error, params in statuses1(data) if sid == dxl_id), None)


def _exchange(bus: DynamixelBus, packet: bytes, dxl_id: int, reply_params: int) -> bytes | None:
    port = bus.serial_port
    want = 6 + reply_params
    deadline = time.monotonic() + bus.reply_timeout_ms(len(packet), want) / 1000.0
    try:
        port.discard_input()
        port.write(packet)
        data = b""
        while len(data) < want:
            got = port.read_until(deadline, want - len(data))
            if not got:
                break
            data += got
    except (OSError, serial.SerialException):
        return None
    return _status(data, dxl_id)


def ping1(bus: DynamixelBus, dxl_id: int) -> tuple[int, int] | None:
    """(model number, firmware) of a Protocol 1.0 servo at ``dxl_id``; None when none answers."""
    if _exchange(bus, _packet(dxl_id, PING), dxl_id, 0) is None:
        return None
    params = _exchange(bus, _packet(dxl_id, READ, bytes([0, 3])), dxl_id, 3)
    if params is None or len(params) < 3:
        return 0, 0  # it answers the ping but not the read: model unknown
    return params[0] | (params[1] << 8), params[2]
