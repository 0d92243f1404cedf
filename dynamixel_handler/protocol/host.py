"""Dynamixel Protocol 2.0 packets: building, byte stuffing, CRC and reply parsing.

Pure functions and small parsers, no I/O, so every rule of the wire format can be
tested byte for byte. We build and parse packets here instead of using
``dynamixel_sdk``'s packet handler because that handler (4.1.0) sends instruction
packets unstuffed, mis-parses fast bulk read replies and drops a whole sync read
when one servo is silent (see ``DynamixelBus`` for the full list).

Wire format (ROBOTIS e-Manual, Protocol 2.0):
``FF FF FD 00 | ID | LEN_L LEN_H | INST | params... | CRC_L CRC_H`` where LEN counts
instruction + (stuffed) params + CRC. A status packet is the same with INST 0x55
followed by an error byte. Byte stuffing turns every ``FF FF FD`` inside
instruction+params into ``FF FF FD FD``; LEN and CRC are computed on the stuffed
bytes. Fast sync/bulk read replies are NOT stuffed and carry one segment per servo
(``ERR ID data... CRC``), each segment's CRC being the running CRC of the packet so
far; only the last one (the packet CRC) is mandatory to check.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Sequence

from . import (  # noqa: F401
    ACTION,
    ALERT_BIT,
    BROADCAST_ID,
    BULK_READ,
    BULK_WRITE,
    CLEAR,
    ERR_CRC,
    ERROR_NAMES,
    FACTORY_RESET,
    FAST_BULK_READ,
    FAST_SYNC_READ,
    HEADER,
    MAX_ID,
    MAX_PACKET_LENGTH,
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

#: Bytes of a status packet without parameters: header(4) id len(2) inst err crc(2).
STATUS_OVERHEAD = 11


def build_instruction(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete, stuffed instruction packet ready for the wire."""
    if not 0 <= dxl_id <= 0xFE or dxl_id == 0xFD:
        raise ValueError(f"invalid Dynamixel ID {dxl_id} (use 0..252 or 254 for broadcast)")
    return frame(dxl_id, bytes([instruction]) + bytes(params))


def build_status(dxl_id: int, error: int, params: bytes = b"") -> bytes:
    """A stuffed status packet (what a servo sends back); used by tests and tools."""
    return frame(dxl_id, bytes([STATUS, error]) + bytes(params))


def u16(value: int) -> bytes:
    return bytes([value & 0xFF, (value >> 8) & 0xFF])


def error_text(error: int) -> str:
    """Human text of a status error byte, e.g. ``'data limit error + hardware alert'``."""
    parts = []
    number = error & 0x7F
    if number:
        parts.append(ERROR_NAMES.get(number, f"error {number}"))
    if error & ALERT_BIT:
        parts.append("hardware alert (read hardware_error_status)")
    return " + ".join(parts) if parts else "ok"


@dataclass(frozen=True)
class Status:
    """One decoded status packet (or one servo's segment of a fast read reply)."""

    dxl_id: int
    error: int
    params: bytes

    @property
    def refused(self) -> bool:
        """True when the servo rejected the instruction (error number set, not just the alert)."""
        return bool(self.error & 0x7F)


class StatusStream(FrameReader):
    """Incremental parser of a byte stream made of (stuffed) status packets.

    ``feed()`` may be called with arbitrary chunks; complete packets with a valid
    CRC come out in order. Noise before a header, bad CRCs and non-status packets
    (e.g. an echoed instruction) are skipped and counted, never returned.
    """

    def __init__(self) -> None:
        super().__init__(min_length=4)  # instruction, error and CRC at least

    def feed(self, data: bytes) -> list[Status]:
        out: list[Status] = []
        for packet_id, body, wire_size in self.frames(data):
            if body[0] != STATUS:
                self.discarded_bytes += wire_size
                continue
            out.append(Status(packet_id, body[1], body[2:]))
        return out


@dataclass
class FastReply:
    """Collector for the single, unstuffed reply of a fast sync/bulk read.

    ``expected`` is the ordered list of ``(id, data_length)`` from the instruction.
    The reply is parsed by position, one segment ``ERR ID data CRC`` per servo in
    that order; the ID byte is checked against the expected ID at that position,
    never searched for (data bytes can equal any ID). A servo that did not answer
    is skipped when the next segment carries a later expected ID; every accepted
    segment is covered by a checked CRC (the packet CRC when the reply is complete,
    else the running CRC each servo appends to its own segment).
    """

    expected: Sequence[tuple[int, int]]
    crc_errors: int = 0
    discarded_bytes: int = 0
    _buffer: bytearray = field(default_factory=bytearray)
    _started: bool = False

    def feed(self, data: bytes) -> None:
        self._buffer += data
        if self._started:
            return
        buf = self._buffer
        while True:
            start = buf.find(HEADER)
            if start < 0:
                drop = max(0, len(buf) - 3)
                self.discarded_bytes += drop
                del buf[:drop]
                return
            if start:
                self.discarded_bytes += start
                del buf[:start]
            if len(buf) < 8:
                return
            if buf[4] == BROADCAST_ID and buf[7] == STATUS:
                self._started = True
                return
            self.discarded_bytes += 1
            del buf[:1]

    @property
    def declared_length(self) -> int | None:
        if not self._started:
            return None
        return self._buffer[5] | (self._buffer[6] << 8)

    @property
    def complete(self) -> bool:
        """True once as many bytes as the header's length field announced have arrived."""
        length = self.declared_length
        return length is not None and len(self._buffer) >= 7 + length

    @property
    def received_bytes(self) -> int:
        return len(self._buffer)

    def segments(self) -> dict[int, Status]:
        """Every servo segment that is positionally consistent and CRC-covered."""
        if not self._started:
            return {}
        buf = bytes(self._buffer)
        length = buf[5] | (buf[6] << 8)
        end = min(len(buf), 7 + length)
        complete = len(buf) >= 7 + length
        packet_ok = complete and crc16(buf[: end - 2]) == (buf[end - 2] | (buf[end - 1] << 8))
        if complete and not packet_ok:
            self.crc_errors += 1
        return self._walk(buf, end, packet_ok)

    def _walk(self, buf: bytes, end: int, packet_ok: bool) -> dict[int, Status]:
        """The segments from the first one on, while each sits where an expected servo's would and
        (when the whole packet's CRC is not good) its own running CRC is right."""
        found: dict[int, Status] = {}
        pos = 8  # first segment starts at the error byte after INST
        index = 0
        order = list(self.expected)
        while pos + 2 <= end and index < len(order):
            seg_id = buf[pos + 1]
            # the servo at this position is the next expected one that answered
            match = next((k for k in range(index, len(order)) if order[k][0] == seg_id), None)
            if match is None:
                break
            crc_at = pos + 2 + order[match][1]
            if crc_at + 2 > end:
                break
            if not packet_ok and crc16(buf[:crc_at]) != (buf[crc_at] | (buf[crc_at + 1] << 8)):
                self.crc_errors += 1
                break
            found[seg_id] = Status(seg_id, buf[pos], buf[pos + 2: crc_at])
            pos = crc_at + 2
            index = match + 1
        return found


def sync_read_params(address: int, length: int, ids: Iterable[int]) -> bytes:
    return u16(address) + u16(length) + bytes(ids)


def sync_write_params(address: int, length: int, data: Iterable[tuple[int, bytes]]) -> bytes:
    out = bytearray(u16(address) + u16(length))
    for dxl_id, chunk in data:
        if len(chunk) != length:
            raise ValueError(f"sync write to ID {dxl_id}: {len(chunk)} bytes given, {length} expected")
        out.append(dxl_id)
        out += chunk
    return bytes(out)


def bulk_read_params(requests: Iterable[tuple[int, int, int]]) -> bytes:
    out = bytearray()
    for dxl_id, address, length in requests:
        out.append(dxl_id)
        out += u16(address) + u16(length)
    return bytes(out)


def bulk_write_params(requests: Iterable[tuple[int, int, bytes]]) -> bytes:
    out = bytearray()
    for dxl_id, address, data in requests:
        out.append(dxl_id)
        out += u16(address) + u16(len(data)) + bytes(data)
    return bytes(out)
