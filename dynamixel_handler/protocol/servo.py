"""Dynamixel Protocol 2.0 framing, as a servo sees it.

The simulator must behave like a real servo on the wire. CRC-16, byte stuffing and framing are
the shared :mod:`dynamixel_handler.protocol` (checked against the e-Manual's example packets);
this module adds the servo's side: an incremental parser that resynchronises on the
``FF FF FD 00`` header after garbage, and status packet builders including the single-packet
Fast Sync/Bulk Read reply.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import (  # noqa: F401
    ACTION,
    ALERT_BIT,
    BACKUP,
    BROADCAST_ID,
    BULK_READ,
    BULK_WRITE,
    CLEAR,
    ERR_ACCESS,
    ERR_CRC,
    ERR_DATA_LENGTH,
    ERR_DATA_LIMIT,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    ERR_NONE,
    ERR_RESULT_FAIL,
    FACTORY_RESET,
    FAST_BULK_READ,
    FAST_SYNC_READ,
    HEADER,
    INSTRUCTION_NAMES,
    MAX_ID,
    PING,
    READ,
    REBOOT,
    REG_WRITE,
    STATUS,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    FrameReader,
    crc16,
    frame,
    stuff,
    unstuff,
)


def build_packet(packet_id: int, instruction: int, params: bytes = b"", *, error: int | None = None) -> bytes:
    """Frame an instruction packet (``error`` None) or a status packet (``error`` given).

    Stuffing covers the instruction, error and parameter bytes; LEN and CRC are computed
    after stuffing, as the e-Manual's transmission order prescribes.
    """
    return frame(packet_id, bytes([instruction]) + (bytes([error]) if error is not None else b"") + bytes(params))


def build_status(packet_id: int, error: int, params: bytes = b"") -> bytes:
    """A normal status packet (instruction 0x55)."""
    return build_packet(packet_id, STATUS, params, error=error)


def build_fast_status(segments: list[tuple[int, int, bytes]], chain_bytes: int) -> bytes:
    """The single packet that answers Fast Sync Read / Fast Bulk Read.

    ``segments`` is the list of (error, id, data) of the devices that answered, in order;
    ``chain_bytes`` is the sum of (error + id + data + CRC) over *all* requested devices,
    because the first device announces LEN for the whole chain before the others append. Each
    device closes its part with the CRC of the packet so far; the last one is the packet CRC.
    The e-Manual states that this reply is not byte-stuffed. A chain cut short by a silent
    device therefore yields a packet shorter than its LEN, as on a real bus.
    """
    out = bytearray()
    crc = 0
    for index, (error, dev_id, data) in enumerate(segments):
        if index == 0:
            length = 1 + chain_bytes
            part = HEADER + bytes([BROADCAST_ID, length & 0xFF, length >> 8, STATUS, error, dev_id]) + bytes(data)
        else:
            part = bytes([error, dev_id]) + bytes(data)
        crc = crc16(part, crc)
        out += part
        out += bytes([crc & 0xFF, crc >> 8])
        crc = crc16(out[-2:], crc)
    return bytes(out)


@dataclass(frozen=True)
class Packet:
    """A received instruction packet, parameters already unstuffed."""

    packet_id: int
    instruction: int
    params: bytes
    wire_size: int  # bytes on the wire, stuffing included (for wire timing)


class PacketParser(FrameReader):
    """Incremental instruction-packet reader tolerant to noise, like a servo's receiver: complete
    packets with a valid CRC come out, garbage, bad-CRC packets and implausible headers are skipped."""

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a packet."""
        return self.pending_bytes

    def feed(self, data: bytes) -> list[Packet]:
        return [Packet(packet_id, body[0], body[1:], wire_size) for packet_id, body, wire_size in self.frames(data)]


def u16(data: bytes, offset: int = 0) -> int:
    return data[offset] | (data[offset + 1] << 8)


def p16(value: int) -> bytes:
    return bytes([value & 0xFF, (value >> 8) & 0xFF])


@dataclass(frozen=True)
class LoggedInstruction:
    """One instruction packet the bus received with a valid CRC."""

    time: float
    instruction: int
    ids: tuple[int, ...]
    address: int | None
    length: int | None
    params: bytes

    @property
    def name(self) -> str:
        return INSTRUCTION_NAMES.get(self.instruction, f"0x{self.instruction:02X}")


def describe(pk: Packet, now: float) -> LoggedInstruction:
    """The log entry of a received packet: its IDs, address and length where it has them."""
    inst, prm = pk.instruction, pk.params
    ids: tuple[int, ...] = (pk.packet_id,)
    address: int | None = None
    length: int | None = None
    try:
        address, length = _address_and_length(inst, prm)
        group = _addressed_ids(inst, prm)
        if group is not None:
            ids = group
    except IndexError:
        pass
    return LoggedInstruction(now, inst, ids, address, length, bytes(prm))


def _address_and_length(inst: int, prm: bytes) -> tuple[int | None, int | None]:
    if inst in (READ, SYNC_READ, FAST_SYNC_READ, SYNC_WRITE) and len(prm) >= 4:
        return u16(prm), u16(prm, 2)
    if inst in (WRITE, REG_WRITE) and len(prm) >= 2:
        return u16(prm), len(prm) - 2
    return None, None


def _addressed_ids(inst: int, prm: bytes) -> tuple[int, ...] | None:
    """The IDs a group instruction addresses; None for an instruction to the packet's own ID."""
    if inst in (SYNC_READ, FAST_SYNC_READ) and len(prm) >= 4:
        return tuple(prm[4:])
    if inst == SYNC_WRITE and len(prm) >= 4:
        length = u16(prm, 2)
        return tuple(prm[k] for k in range(4, len(prm), 1 + length)) if length else ()
    if inst in (BULK_READ, FAST_BULK_READ):
        return tuple(prm[k] for k in range(0, len(prm) - 4, 5))
    if inst == BULK_WRITE:
        found, k = [], 0
        while k + 5 <= len(prm):
            found.append(prm[k])
            k += 5 + u16(prm, k + 3)
        return tuple(found)
    return None
