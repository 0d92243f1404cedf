"""The Dynamixel wire formats, the one place for them. Protocol 2.0 here: header, instruction and
error codes, CRC-16, byte stuffing, packet framing and the noise-tolerant packet reader, the host
side (``host``: instruction packets, reply parsing, used by the bus layer) and the servo side
(``servo``: instruction parsing, status and fast-read replies, used by the virtual bus). Protocol 1.0
in ``protocol1``; ``framers`` gives the bus one framer per protocol.

Both sides are checked byte for byte against the ROBOTIS e-Manual's example packets (and the bus
layer's CRC against ``dynamixel_sdk``'s), so sharing this code hides nothing from the tests.
"""
from __future__ import annotations

import struct
from typing import Iterable

import numpy as np

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
MAX_ID = 0xFC
MAX_PACKET_LENGTH = 4096

# Instructions
PING, READ, WRITE, REG_WRITE, ACTION = 0x01, 0x02, 0x03, 0x04, 0x05
FACTORY_RESET, REBOOT, CLEAR, STATUS = 0x06, 0x08, 0x10, 0x55
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ = 0x82, 0x83, 0x8A
BULK_READ, BULK_WRITE, FAST_BULK_READ = 0x92, 0x93, 0x9A
BACKUP = 0x20  # Control Table Backup (store / restore the EEPROM area)

INSTRUCTION_NAMES = {
    BACKUP: "backup",
    PING: "ping", READ: "read", WRITE: "write", REG_WRITE: "reg_write", ACTION: "action",
    FACTORY_RESET: "factory_reset", REBOOT: "reboot", CLEAR: "clear", STATUS: "status",
    SYNC_READ: "sync_read", SYNC_WRITE: "sync_write", FAST_SYNC_READ: "fast_sync_read",
    BULK_READ: "bulk_read", BULK_WRITE: "bulk_write", FAST_BULK_READ: "fast_bulk_read",
}

# Status error numbers (bits 0..6 of the error byte); bit 7 is the hardware alert
ERR_NONE, ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC = 0x00, 0x01, 0x02, 0x03
ERR_DATA_RANGE, ERR_DATA_LENGTH, ERR_DATA_LIMIT, ERR_ACCESS = 0x04, 0x05, 0x06, 0x07
ALERT_BIT = 0x80

ERROR_NAMES = {
    ERR_RESULT_FAIL: "result fail", ERR_INSTRUCTION: "instruction error", ERR_CRC: "CRC error",
    ERR_DATA_RANGE: "data range error", ERR_DATA_LENGTH: "data length error",
    ERR_DATA_LIMIT: "data limit error", ERR_ACCESS: "access error",
}


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _crc_table()


def _crc_table16() -> list[int]:
    """The register after two bytes at once: for a 16-bit CRC fed 16 bits, the new register
    depends only on ``crc ^ (b0 << 8 | b1)``, so one lookup replaces two byte steps."""
    t8 = np.array(_CRC_TABLE, dtype=np.uint32)
    x = np.arange(1 << 16, dtype=np.uint32)
    first = t8[x >> 8]
    return [int(v) for v in ((first & 0xFF) << 8) ^ t8[(x & 0xFF) ^ (first >> 8)]]


_CRC_TABLE16 = _crc_table16()
_WORDS: dict[int, struct.Struct] = {}  # big-endian 16-bit word readers by word count


def crc16(data: bytes | bytearray | memoryview | Iterable[int], crc: int = 0) -> int:
    """CRC-16 of Protocol 2.0 (polynomial 0x8005, init 0, not reflected). ``crc`` continues an
    accumulation, which the fast-read reply needs: each servo's CRC there covers the packet so far.
    Two bytes a step (``crc16_bytewise`` gives the same value a byte at a time)."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        data = bytes(data)
    size = len(data)
    words = _WORDS.get(size >> 1)
    if words is None:
        words = _WORDS.setdefault(size >> 1, struct.Struct(f">{size >> 1}H"))
    table = _CRC_TABLE16
    for word in words.unpack_from(data):
        crc = table[crc ^ word]
    if size & 1:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ data[size - 1]) & 0xFF]) & 0xFFFF
    return crc


def crc16_bytewise(data: bytes | bytearray | memoryview | Iterable[int], crc: int = 0) -> int:
    """``crc16`` one byte at a time, as the e-Manual's table-driven example computes it."""
    table = _CRC_TABLE
    for byte in data:
        crc = ((crc << 8) ^ table[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert 0xFD after every ``FF FF FD`` of instruction+params, so the body never holds a header."""
    if b"\xff\xff\xfd" not in body:
        return bytes(body)
    out = bytearray()
    for i, byte in enumerate(body):
        out.append(byte)
        if byte == 0xFD and i >= 2 and body[i - 1] == 0xFF and body[i - 2] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Inverse of :func:`stuff`: ``FF FF FD FD`` -> ``FF FF FD``."""
    if b"\xff\xff\xfd\xfd" not in body:
        return bytes(body)
    out = bytearray()
    i, n = 0, len(body)
    while i < n:
        out.append(body[i])
        if body[i] == 0xFD and i >= 2 and body[i - 1] == 0xFF and body[i - 2] == 0xFF \
                and i + 1 < n and body[i + 1] == 0xFD:
            i += 1  # skip the stuffing byte
        i += 1
    return bytes(out)


def frame(packet_id: int, body: bytes) -> bytes:
    """Header, ID, length, the stuffed body (instruction or status+error, then params) and CRC;
    LEN and CRC are computed on the stuffed bytes, as the e-Manual prescribes."""
    body = stuff(body)
    length = len(body) + 2
    packet = HEADER + bytes([packet_id, length & 0xFF, length >> 8]) + body
    crc = crc16(packet)
    return packet + bytes([crc & 0xFF, crc >> 8])


class FrameReader:
    """Incremental reader of (stuffed) Protocol 2.0 packets from a noisy byte stream.

    ``frames()`` takes whatever the port delivered and returns the complete packets with a valid
    CRC as ``(id, unstuffed body, bytes on the wire)``; garbage before a header, implausible
    headers and bad CRCs are skipped and counted, the search restarting one byte later (the real
    header may be inside), as a servo's or host's receiver does.
    """

    def __init__(self, min_length: int = 3) -> None:
        self.min_length = min_length
        self.crc_errors = 0
        self.discarded_bytes = 0
        self._buf = bytearray()

    @property
    def pending_bytes(self) -> int:
        """Bytes held while waiting for the rest of a packet."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget a partial packet (e.g. after an inter-byte timeout)."""
        self.discarded_bytes += len(self._buf)
        self._buf.clear()

    def frames(self, data: bytes) -> list[tuple[int, bytes, int]]:
        buf = self._buf
        buf += data
        out: list[tuple[int, bytes, int]] = []
        pos, size = 0, len(buf)  # packets are read at an offset; the buffer is cut once at the end
        while True:
            start = buf.find(HEADER, pos)
            if start < 0:  # no header: keep what may be the start of one
                keep = next((k for k in (3, 2, 1) if size - pos >= k and buf[size - k:] == HEADER[:k]), 0)
                self.discarded_bytes += size - keep - pos
                pos = size - keep
                break
            self.discarded_bytes += start - pos
            pos = start
            if size - pos < 7:
                break
            packet_id, length = buf[pos + 4], buf[pos + 5] | (buf[pos + 6] << 8)
            if packet_id in (0xFD, 0xFF) or length < self.min_length or length > MAX_PACKET_LENGTH:
                self.discarded_bytes += 1
                pos += 1
                continue
            end = pos + 7 + length
            if end > size:
                break
            with memoryview(buf) as view:
                crc = crc16(view[pos: end - 2])
            if crc != buf[end - 2] | (buf[end - 1] << 8):
                self.crc_errors += 1
                self.discarded_bytes += 1
                pos += 1
                continue
            out.append((packet_id, unstuff(bytes(buf[pos + 7: end - 2])), end - pos))
            pos = end
        del buf[:pos]
        return out

