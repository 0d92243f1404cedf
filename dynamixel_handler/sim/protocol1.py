"""Protocol 1.0 on the virtual bus: packets, and what its Protocol 1.0 servos do with them.

The servos are the AX, RX, DX, EX and MX (Protocol 1.0 firmware) models of ``control_table``
(``protocol1_models()``: their tables, units and factory values), each a ``VirtualServo`` as every
other, with the Protocol 1.0 firmware (``firmware.PROTOCOL1``: its write rules, error bits and baud
rates). They answer Protocol 1.0 packets
(``FF FF ID LEN INST PARAMS CHK``, the checksum being the inverted low byte of the sum from ID on)
and ignore Protocol 2.0 ones, as the 2.0 servos ignore theirs, so a 2.0 and a 1.0 servo on one ID
do not collide: each hears only its own protocol.

Facts (ROBOTIS e-Manual, "Protocol 1.0" and the models' pages): PING 0x01, READ 0x02, WRITE 0x03,
REG WRITE 0x04, ACTION 0x05, RESET 0x06 (factory values), SYNC WRITE 0x83 and BULK READ 0x92 (MX and
EX; AX, RX and DX do not know it and stay silent); any other instruction gets the Instruction Error
bit, and so does an Action with nothing registered. Status Return Level 0 answers only PING, 1 also
READ, 2 everything; a broadcast (ID 254) is never answered. A packet whose checksum is wrong gets the
Checksum Error bit from the servo it names. In a Bulk Read, each servo answers after the status
packet of the one listed before it (a listed ID that does not answer ends the replies); an ID listed
twice answers once. Baud Rate value v runs at 2,000,000 / (v + 1) bps, and less than 3 % of error
does not affect the UART, so a servo hears a host within 3 % of its rate.

A Protocol 2.0 servo whose Protocol Type is set to 1 (X series: "1: DYNAMIXEL Protocol 1.0") answers
these packets too, with its own control table (the 1.0 packet's one-byte address reaches the first
256 bytes); writing Protocol Type 2 back through Protocol 1.0 returns it to 2.0.
"""

from __future__ import annotations

import collections
from typing import Callable

from dynamixel_handler.control_table import Model, protocol1_models

from ..protocol import protocol1 as p1
from ..protocol import servo as p2
from ..protocol.protocol1 import ERR_CHECKSUM, ERR_RANGE, checksum
from ..protocol.servo import ERR_DATA_RANGE
from ..protocol.servo import ERR_INSTRUCTION as ERR_UNKNOWN
from .faults import Replies
from .servo import VirtualServo

__all__ = ["PROTOCOL1_MODELS", "PROTOCOL", "Protocol1Instructions", "Protocol1Parser", "build_instruction1",
           "build_status1", "checksum", "protocol1_model"]

#: the protocol these packets are (a servo hears them when it answers this protocol)
PROTOCOL = 1

HEADER1 = p1.HEADER
BROADCAST_ID1 = p1.BROADCAST_ID
PING1, READ1, WRITE1, REG_WRITE1, ACTION1, RESET1 = p1.PING, p1.READ, p1.WRITE, p1.REG_WRITE, p1.ACTION, p1.RESET
SYNC_WRITE1, BULK_READ1 = p1.SYNC_WRITE, p1.BULK_READ
KNOWN_INSTRUCTIONS1 = p1.INSTRUCTIONS
_MAX_LENGTH = p1.MAX_LENGTH  # the longest instruction packet an AX/MX buffer takes (143 bytes of parameters)

PROTOCOL1_MODELS: dict[int, Model] = {m.number: m for m in protocol1_models()}
"""Protocol 1.0 models by number (``control_table.protocol1_models()``)."""


def protocol1_model(text: str | int) -> Model | None:
    """The Protocol 1.0 model of a number or a name (case-insensitive; "MX-28(1.0)" as well as
    "MX-28", "AX-12" and "AX-12+" for the AX-12A), or None."""
    key = str(text).strip().lower()
    if key in ("ax-12", "ax-12+"):
        key = "ax-12a"
    for model in PROTOCOL1_MODELS.values():
        if key in (str(model.number), model.name.lower(), f"{model.name.lower()}(1.0)"):
            return model
    return None


def build_status1(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """A status packet (the shared Protocol 1.0 framing, ``protocol.protocol1``)."""
    return p1.build_packet(servo_id, error, params)


def build_instruction1(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """An instruction packet, unchecked (a test may send what no host would)."""
    return p1.build_packet(servo_id, instruction, params)


class Protocol1Parser:
    """Incremental reader of Protocol 1.0 instruction packets, resynchronising after noise as a
    servo's receiver does. A Protocol 2.0 header (``FF FF FD 00``) reads as ID 253 with length 0
    and is skipped, so 2.0 traffic passes by. A packet whose checksum is wrong comes out with
    ``BAD_CHECKSUM`` added to its instruction (its servo answers with the Checksum Error bit)."""

    def __init__(self) -> None:
        self._buf = bytearray()

    @property
    def pending(self) -> int:
        return len(self._buf)

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[p2.Packet]:
        buf = self._buf
        buf += data
        out: list[p2.Packet] = []
        pos = 0
        while True:
            start = buf.find(HEADER1, pos)
            if start < 0:
                pos = len(buf) - 1 if buf.endswith(b"\xff") else len(buf)
                break
            pos = start
            if len(buf) - pos < 6:
                break
            servo_id, length, inst = buf[pos + 2], buf[pos + 3], buf[pos + 4]
            if servo_id == 0xFF or not 2 <= length <= _MAX_LENGTH or inst not in KNOWN_INSTRUCTIONS1:
                pos += 1
                continue
            end = pos + 4 + length
            if end > len(buf):
                break
            if checksum(buf[pos + 2:end - 1]) != buf[end - 1]:
                out.append(p2.Packet(servo_id, inst | BAD_CHECKSUM, b"", end - pos))
                pos += 1  # it may be another protocol's bytes: read on from the next byte
                continue
            out.append(p2.Packet(servo_id, inst, bytes(buf[pos + 5:end - 1]), end - pos))
            pos = end
        del buf[:pos]
        return out


BAD_CHECKSUM = 0x100


class Protocol1Instructions:
    """What the servos of the bus that answer Protocol 1.0 do with a 1.0 packet (see the module):
    the Protocol 1.0 families' servos, and a Protocol 2.0 servo set to Protocol Type 1. ``servos`` is
    the bus's list. A servo's refusal comes back as the status bit its firmware gives it
    (``Firmware.protocol1_bits``)."""

    def __init__(self, servos: list[VirtualServo], stats: collections.Counter[str], clock: Callable[[], float]) -> None:
        self._servos = servos
        self.stats = stats
        self.clock = clock
        self.line_bps: int | None = None

    def _hearing(self, packet_id: int) -> list[VirtualServo]:
        hearing = [s for s in self._servos if not s.silent and s.protocol == PROTOCOL and s.hears(self.line_bps)]
        if packet_id == BROADCAST_ID1:
            return hearing
        return [s for s in hearing if s.id == packet_id]

    def execute(self, packet: p2.Packet) -> Replies:
        self.stats["protocol1_instructions"] += 1
        now = self.clock()
        if packet.instruction == SYNC_WRITE1:
            self._sync_write(packet.params, now)
            return []
        if packet.instruction == BULK_READ1:
            return self._bulk_read(packet.params, now)
        out: Replies = []
        for servo in self._hearing(packet.packet_id):
            before = (servo.id, servo.status_return_level)
            if packet.instruction & BAD_CHECKSUM:
                bits, data = ERR_CHECKSUM | _status_bits(servo, 0), b""
            else:
                error, data = _ONE.get(packet.instruction, _unknown)(servo, packet.params, now)
                bits = _status_bits(servo, error)
            if _answers(packet, before[1]):
                out.append((servo.return_delay_s, build_status1(before[0], bits, data)))
        return out

    def _sync_write(self, prm: bytes, now: float) -> None:
        if len(prm) < 2:
            return
        address, length = prm[0], prm[1]
        for k in range(2, len(prm) - length, 1 + length):
            for servo in self._hearing(prm[k]):
                servo.host_write(address, prm[k + 1:k + 1 + length], now)

    def _bulk_read(self, prm: bytes, now: float) -> Replies:
        """Each listed servo in turn, right after the one before it (the first after its Return
        Delay Time); the replies stop at a listed ID that does not answer."""
        out: Replies = []
        seen: set[int] = set()
        for k in range(1, len(prm) - 2, 3):
            length, servo_id, address = prm[k], prm[k + 1], prm[k + 2]
            if servo_id in seen:
                continue
            seen.add(servo_id)
            servos = [s for s in self._hearing(servo_id) if _bulk_read(s)] if servo_id != BROADCAST_ID1 else []
            if not servos:
                break
            for servo in servos:
                error, data = servo.host_read(address, length, now)
                delay = servo.return_delay_s if not out else 0.0
                out.append((delay, build_status1(servo.id, _status_bits(servo, error), data)))
        return out


def _bulk_read(servo: VirtualServo) -> bool:
    """It answers a Bulk Read (MX and EX; AX, RX and DX do not know the instruction)."""
    return servo.firmware.bulk_read1 and servo.model.family.bulk_read


def _status_bits(servo: VirtualServo, error: int) -> int:
    """A status packet's error byte: the refusal ``error`` (an engine code) as the bit the servo's
    firmware gives it, plus the conditions of the moment where its family reports them there."""
    servo.refresh()
    bit = servo.firmware.protocol1_bits.get(error, ERR_RANGE) if error else 0
    return bit | servo.errors.in_status()


def _answers(packet: p2.Packet, level: int) -> bool:
    """Whether a status packet goes back: never to a broadcast, else as Status Return Level says."""
    if packet.packet_id == BROADCAST_ID1:
        return False
    instruction = packet.instruction & 0xFF
    return instruction == PING1 or level == 2 or (level == 1 and instruction == READ1)


Done = tuple[int, bytes]


def _read(servo: VirtualServo, prm: bytes, now: float) -> Done:
    return servo.host_read(prm[0], prm[1], now) if len(prm) == 2 else (ERR_DATA_RANGE, b"")


def _write(servo: VirtualServo, prm: bytes, now: float) -> Done:
    return (servo.host_write(prm[0], prm[1:], now) if len(prm) >= 2 else ERR_DATA_RANGE), b""


def _reg_write(servo: VirtualServo, prm: bytes, now: float) -> Done:
    return (servo.reg_write(prm[0], prm[1:], now) if len(prm) >= 2 else ERR_DATA_RANGE), b""


def _action(servo: VirtualServo, prm: bytes, now: float) -> Done:
    return servo.action(now), b""


def _reset(servo: VirtualServo, prm: bytes, now: float) -> Done:
    servo.factory_reset(0xFF, now)
    return 0, b""


def _unknown(servo: VirtualServo, prm: bytes, now: float) -> Done:
    return ERR_UNKNOWN, b""


_ONE: dict[int, Callable[[VirtualServo, bytes, float], Done]] = {
    PING1: lambda servo, prm, now: (0, b""), READ1: _read, WRITE1: _write, REG_WRITE1: _reg_write,
    ACTION1: _action, RESET1: _reset,
}
