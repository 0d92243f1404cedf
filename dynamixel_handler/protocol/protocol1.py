"""Dynamixel Protocol 1.0, the wire format of the AX, RX, DX, EX and MX (1.0 firmware) servos, for
both sides: the host's instruction packets and status parsing (the bus layer, the set-up tool's
scan and trace) and the servo's instruction parsing and status packets (the virtual bus).

Facts (ROBOTIS e-Manual, "DYNAMIXEL Protocol 1.0"): an instruction packet is
``FF FF ID LEN INST PARAMS... CHECKSUM`` and a status packet ``FF FF ID LEN ERROR PARAMS...
CHECKSUM``; LEN counts the parameters plus 2; the checksum is the inverted low byte of the sum of
ID, LEN, INST/ERROR and the parameters. No byte stuffing, no CRC. Broadcast ID 254 (never answered),
IDs 0..253. Addresses and lengths are one byte each (READ: address, length; WRITE: address,
data...; SYNC WRITE: address, length per servo, then ID and data per servo; BULK READ: 0x00, then
length, ID, address per servo). The status error byte is a set of bits: 0 input voltage, 1 angle
limit, 2 overheating, 3 range, 4 checksum, 5 overload, 6 instruction. The servo did not carry out
an instruction whose status has the angle limit, range, checksum or instruction bit; the others
(voltage, overheating, overload) report its state, the instruction done all the same (as the alert
bit of Protocol 2.0).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

HEADER = b"\xff\xff"
BROADCAST_ID = 0xFE
MAX_ID = 0xFD
#: bytes of a status packet without parameters: header(2) id len err checksum
STATUS_OVERHEAD = 6
#: the longest LEN a servo's buffer takes (143 bytes of parameters)
MAX_LENGTH = 0x8F

PING, READ, WRITE, REG_WRITE, ACTION, RESET, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08
SYNC_WRITE, BULK_READ = 0x83, 0x92
INSTRUCTIONS = (PING, READ, WRITE, REG_WRITE, ACTION, RESET, REBOOT, SYNC_WRITE, BULK_READ)
INSTRUCTION_NAMES = {PING: "ping", READ: "read", WRITE: "write", REG_WRITE: "reg_write", ACTION: "action",
                     RESET: "reset", REBOOT: "reboot", SYNC_WRITE: "sync_write", BULK_READ: "bulk_read"}

#: the status error byte's bits, from bit 0
ERROR_BITS = ("input voltage", "angle limit", "overheating", "range", "checksum", "overload", "instruction")
ERR_VOLTAGE, ERR_ANGLE_LIMIT, ERR_OVERHEATING, ERR_RANGE = 0x01, 0x02, 0x04, 0x08
ERR_CHECKSUM, ERR_OVERLOAD, ERR_INSTRUCTION = 0x10, 0x20, 0x40
#: the bits that say the instruction was not carried out
REFUSING_BITS = ERR_ANGLE_LIMIT | ERR_RANGE | ERR_CHECKSUM | ERR_INSTRUCTION


def checksum(body: bytes | bytearray | memoryview) -> int:
    """The checksum of ID, LEN, INST/ERROR and the parameters."""
    return ~sum(body) & 0xFF


def build_packet(packet_id: int, code: int, params: bytes = b"") -> bytes:
    """A packet: an instruction (``code`` the instruction) or a status (``code`` the error byte)."""
    body = bytes([packet_id, len(params) + 2, code]) + bytes(params)
    return HEADER + body + bytes([checksum(body)])


def build_instruction(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete instruction packet ready for the wire; ValueError for an ID out of 0..254 or
    parameters a servo's buffer does not take."""
    if not 0 <= dxl_id <= BROADCAST_ID:
        raise ValueError(f"invalid Protocol 1.0 ID {dxl_id} (use 0..253 or 254 for broadcast)")
    if len(params) + 2 > MAX_LENGTH:
        raise ValueError(f"a Protocol 1.0 packet takes at most {MAX_LENGTH - 2} bytes of parameters, got {len(params)}")
    return build_packet(dxl_id, instruction, params)


def error_text(error: int) -> str:
    """A status error byte in words ("no error" when 0)."""
    named = [name for bit, name in enumerate(ERROR_BITS) if error >> bit & 1]
    return ", ".join(named) + f" error (0x{error:02X})" if named else "no error"


def read_params(address: int, size: int) -> bytes:
    return bytes([address, size])


def write_params(address: int, data: bytes) -> bytes:
    return bytes([address]) + bytes(data)


def sync_write_params(address: int, length: int, data: Iterable[tuple[int, bytes]]) -> bytes:
    """Address, length, then ID and ``length`` bytes per servo (ValueError for another length)."""
    out = bytearray([address, length])
    for dxl_id, chunk in data:
        if len(chunk) != length:
            raise ValueError(f"sync write data for ID {dxl_id} has {len(chunk)} bytes, expected {length}")
        out.append(dxl_id)
        out += chunk
    return bytes(out)


def bulk_read_params(requests: Iterable[tuple[int, int, int]]) -> bytes:
    """``(id, address, size)`` per servo: 0x00, then length, ID, address each."""
    out = bytearray([0x00])
    for dxl_id, address, size in requests:
        out += bytes([size, dxl_id, address])
    return bytes(out)


@dataclass(frozen=True)
class Status1:
    """One status packet: ID, error byte and parameters."""

    dxl_id: int
    error: int
    params: bytes

    @property
    def refused(self) -> bool:
        """True when the servo did not carry out the instruction (angle limit, range, checksum or
        instruction error); voltage, overheating and overload only report its state."""
        return bool(self.error & REFUSING_BITS)


class PacketReader:
    """Incremental reader of Protocol 1.0 packets from a noisy byte stream, for either side.

    ``frames()`` returns the complete packets with a valid checksum as ``(id, code, params, bytes on
    the wire)``, in order; noise, implausible headers and bad checksums are skipped and counted, the
    search restarting one byte later, as a servo's or a host's receiver does. ``codes``: the
    instruction codes accepted (an instruction reader); None accepts any code (a status reader).
    A Protocol 2.0 header (``FF FF FD 00``) reads as ID 253 with length 0 and is skipped."""

    def __init__(self, codes: Iterable[int] | None = None) -> None:
        self.codes = frozenset(codes) if codes is not None else None
        self.crc_errors = 0
        self.discarded_bytes = 0
        self._buf = bytearray()

    @property
    def pending_bytes(self) -> int:
        return len(self._buf)

    def reset(self) -> None:
        self.discarded_bytes += len(self._buf)
        self._buf.clear()

    def frames(self, data: bytes) -> list[tuple[int, int, bytes, int]]:
        buf = self._buf
        buf += data
        out: list[tuple[int, int, bytes, int]] = []
        pos = 0
        while True:
            start = buf.find(HEADER, pos)
            if start < 0:
                keep = 1 if buf.endswith(b"\xff") and len(buf) > pos else 0
                self.discarded_bytes += len(buf) - keep - pos
                pos = len(buf) - keep
                break
            self.discarded_bytes += start - pos
            pos = start
            if len(buf) - pos < STATUS_OVERHEAD:
                break
            packet_id, length, code = buf[pos + 2], buf[pos + 3], buf[pos + 4]
            if packet_id == 0xFF or not 2 <= length <= MAX_LENGTH or (self.codes is not None and code not in self.codes):
                self.discarded_bytes += 1
                pos += 1
                continue
            end = pos + 4 + length
            if end > len(buf):
                break
            if checksum(buf[pos + 2:end - 1]) != buf[end - 1]:
                self.crc_errors += 1
                self.discarded_bytes += 1
                pos += 1
                continue
            out.append((packet_id, code, bytes(buf[pos + 5:end - 1]), end - pos))
            pos = end
        del buf[:pos]
        return out


class StatusStream1(PacketReader):
    """The host's reader of status packets (``feed`` -> ``Status1`` values)."""

    def feed(self, data: bytes) -> list[Status1]:
        return [Status1(i, code, params) for i, code, params, _ in self.frames(data)]


def statuses(data: bytes) -> list[Status1]:
    """Every valid status packet in ``data`` (noise and bad checksums skipped)."""
    return StatusStream1().feed(data)
