"""Dynamixel Protocol 2.0 framing, as a servo sees it.

The simulator must behave like a real servo on the wire, so this module implements the
e-Manual rules independently of any host library: CRC-16 (polynomial 0x8005), byte
stuffing (``FF FF FD`` -> ``FF FF FD FD`` between the instruction byte and the CRC), an
incremental parser that resynchronises on the ``FF FF FD 00`` header after garbage, and
status packet builders including the single-packet Fast Sync/Bulk Read reply.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
MAX_ID = 0xFC

# Instructions (e-Manual protocol 2.0)
PING = 0x01
READ = 0x02
WRITE = 0x03
REG_WRITE = 0x04
ACTION = 0x05
FACTORY_RESET = 0x06
REBOOT = 0x08
CLEAR = 0x10
STATUS = 0x55
SYNC_READ = 0x82
SYNC_WRITE = 0x83
FAST_SYNC_READ = 0x8A
BULK_READ = 0x92
BULK_WRITE = 0x93
FAST_BULK_READ = 0x9A

INSTRUCTION_NAMES = {
    PING: "ping", READ: "read", WRITE: "write", REG_WRITE: "reg_write", ACTION: "action",
    FACTORY_RESET: "factory_reset", REBOOT: "reboot", CLEAR: "clear", STATUS: "status",
    SYNC_READ: "sync_read", SYNC_WRITE: "sync_write", FAST_SYNC_READ: "fast_sync_read",
    BULK_READ: "bulk_read", BULK_WRITE: "bulk_write", FAST_BULK_READ: "fast_bulk_read",
}

# Error numbers of the status packet (bit 7 is the alert flag)
ERR_NONE = 0x00
ERR_RESULT_FAIL = 0x01
ERR_INSTRUCTION = 0x02
ERR_CRC = 0x03
ERR_DATA_RANGE = 0x04
ERR_DATA_LENGTH = 0x05
ERR_DATA_LIMIT = 0x06
ERR_ACCESS = 0x07
ALERT_BIT = 0x80

# Largest LEN field we accept; a longer one is garbage that merely looks like a header.
MAX_LENGTH = 4096


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray | Iterable[int], crc: int = 0) -> int:
    """CRC-16/BUYPASS as specified by the e-Manual (poly 0x8005, init 0, no reflection).

    ``crc`` lets a caller continue an accumulation, which the fast-read reply needs: each
    device's CRC there covers the whole packet sent so far.
    """
    table = _CRC_TABLE
    for byte in data:
        crc = ((crc << 8) ^ table[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert an extra 0xFD after every ``FF FF FD`` so the body never contains a header."""
    if b"\xff\xff\xfd" not in body:
        return bytes(body)
    out = bytearray()
    ff_run = 0
    for byte in body:
        out.append(byte)
        if byte == 0xFD and ff_run >= 2:
            out.append(0xFD)
            ff_run = 0
        elif byte == 0xFF:
            ff_run += 1
        else:
            ff_run = 0
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Drop the 0xFD that follows each ``FF FF FD`` (inverse of :func:`stuff`)."""
    if b"\xff\xff\xfd\xfd" not in body:
        return bytes(body)
    out = bytearray()
    i = 0
    n = len(body)
    while i < n:
        out.append(body[i])
        if body[i] == 0xFD and i >= 2 and body[i - 1] == 0xFF and body[i - 2] == 0xFF \
                and i + 1 < n and body[i + 1] == 0xFD:
            i += 2
            continue
        i += 1
    return bytes(out)


def build_packet(packet_id: int, instruction: int, params: bytes = b"", *, error: int | None = None) -> bytes:
    """Frame an instruction packet (``error`` None) or a status packet (``error`` given).

    Stuffing covers the instruction, error and parameter bytes; LEN and CRC are computed
    after stuffing, as the e-Manual's transmission order prescribes.
    """
    body = bytes([instruction]) + (bytes([error]) if error is not None else b"") + bytes(params)
    body = stuff(body)
    length = len(body) + 2
    head = HEADER + bytes([packet_id, length & 0xFF, length >> 8])
    packet = head + body
    crc = crc16(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


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


class PacketParser:
    """Incremental instruction-packet reader tolerant to noise.

    Feed it whatever the pty delivered; it returns complete packets with a valid CRC and
    silently skips garbage, bad-CRC packets and implausible headers, restarting its search
    one byte after a rejected header like a servo's receiver state machine.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.crc_errors = 0
        self.discarded_bytes = 0

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a packet."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget a partial packet (used after an inter-byte timeout)."""
        self.discarded_bytes += len(self._buf)
        self._buf.clear()

    def feed(self, data: bytes) -> list[Packet]:
        self._buf += data
        packets: list[Packet] = []
        buf = self._buf
        while True:
            start = buf.find(HEADER)
            if start < 0:
                # keep a possible header prefix at the end
                keep = 0
                for k in (3, 2, 1):
                    if len(buf) >= k and buf[-k:] == HEADER[:k]:
                        keep = k
                        break
                self.discarded_bytes += len(buf) - keep
                del buf[: len(buf) - keep]
                break
            if start:
                self.discarded_bytes += start
                del buf[:start]
            if len(buf) < 7:
                break
            packet_id = buf[4]
            length = buf[5] | (buf[6] << 8)
            if packet_id in (0xFD, 0xFF) or length < 3 or length > MAX_LENGTH:
                del buf[:1]
                self.discarded_bytes += 1
                continue
            total = 7 + length
            if len(buf) < total:
                break
            raw = bytes(buf[:total])
            crc = raw[-2] | (raw[-1] << 8)
            if crc16(raw[:-2]) != crc:
                self.crc_errors += 1
                del buf[:1]
                self.discarded_bytes += 1
                continue
            del buf[:total]
            body = unstuff(raw[7:-2])
            packets.append(Packet(packet_id, body[0], body[1:], total))
        return packets


def u16(data: bytes, offset: int = 0) -> int:
    return data[offset] | (data[offset + 1] << 8)


def p16(value: int) -> bytes:
    return bytes([value & 0xFF, (value >> 8) & 0xFF])
