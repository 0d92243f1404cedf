"""``MemoryLine``: a line (``dynamixel_handler.bus.line.Line``) of servos in memory, for unit tests of
the core's parts under the real ``DynamixelBus`` (``support.fake_bus.FakeBus`` is that bus).

Each servo is a raw register image of its model (``MemoryServo``): what is written is read back as
written, with none of a firmware's rules (read-only items, ranges, torque locks), no physics and no
timing; it always answers (Status Return Level 2) unless the test silences it. Each packet the bus
writes is parsed by the product's parsers (Protocol 2.0: ``protocol.servo.PacketParser``; Protocol
1.0: ``sim.protocol1.Protocol1Parser``) and executed over those images by the virtual bus's
instruction sets (``sim.instructions.InstructionSet``, ``sim.protocol1.Protocol1Instructions``); the
status packets wait to be read at once, as ``dummy.InProcessLine``'s do.

Every packet handed to ``write`` is also noted in ``calls`` as one tuple (``_call2``, ``_call1``), so a
test sees the instructions that reached the line. Switches for the faults a part must survive:
``silent`` (IDs that answer nothing), ``no_fast`` (IDs that do not answer Fast Sync/Bulk Read: old
firmware), ``errors`` (Protocol 1.0: the error bits of an ID's statuses), ``fail_sync_writes`` (a
sync write fails in ``write`` as the serial port's write does when the adapter is gone), ``lost``
(the device gone) and ``can_reopen`` (False: ``open`` fails as for a missing device).
"""
from __future__ import annotations

import collections
import time
from typing import Any, Mapping

import serial

from dynamixel_handler import units
from dynamixel_handler.bus.errors import BusError
from dynamixel_handler.control_table import Model
from dynamixel_handler.dummy import InProcessLine
from dynamixel_handler.protocol import protocol1 as p1
from dynamixel_handler.protocol import servo as p2
from dynamixel_handler.sim.firmware import firmware_of
from dynamixel_handler.sim.instructions import InstructionSet
from dynamixel_handler.sim.protocol1 import Protocol1Instructions, Protocol1Parser

#: bytes of each servo's register image
MEMORY = 1024


class MemoryServo:
    """One servo as the virtual bus's instruction sets see a servo (the members of
    ``sim.servo.VirtualServo`` they use), its registers a raw image: ``host_read`` gives the bytes,
    ``host_write`` takes them as they come and never refuses. The image is zeros but for its Secondary
    ID (255: none)."""

    return_delay_s = 0.0
    status_return_level = 2

    def __init__(self, line: MemoryLine, model: Model, dxl_id: int) -> None:
        self.model = model
        self.id = dxl_id
        self.memory = bytearray(MEMORY)
        #: the firmware of its family, for how a Protocol 1.0 status reports a refusal
        self.firmware = firmware_of(model)
        self.registers = self
        self.errors = self
        self._line = line
        self._registered: tuple[int, bytes] | None = None
        if model.has("secondary_id"):  # none (255, its factory value): a write to ID 0 is not for it
            self.host_write(model.item("secondary_id").address, b"\xff")

    # ------------------------------------------------------------ what the instruction sets ask
    @property
    def protocol(self) -> int:
        return self.model.protocol

    @property
    def silent(self) -> bool:
        return self.id in self._line.silent

    @property
    def supports_fast_read(self) -> bool:
        return self.id not in self._line.no_fast

    def hears(self, line_bps: int | None) -> bool:
        return True

    def peek(self, item: str) -> int:
        spec = self.model.item(item)
        return int(units.decode(spec, bytes(self.memory[spec.address:spec.address + spec.size]))[0])

    def in_status(self) -> int:
        """Protocol 1.0: the error bits of each of its statuses (the test's ``errors``)."""
        return self._line.errors.get(self.id, 0)

    def refresh(self, now: float | None = None) -> float:
        return time.monotonic() if now is None else now

    def note_instruction(self, now: float) -> None:
        pass

    def error_flags(self, error: int) -> int:
        return error

    def host_read(self, address: int, length: int, now: float | None = None) -> tuple[int, bytes]:
        return p2.ERR_NONE, bytes(self.memory[address:address + length])

    def host_write(self, address: int, data: bytes, now: float | None = None) -> int:
        self.memory[address:address + len(data)] = data
        return p2.ERR_NONE

    def reg_write(self, address: int, data: bytes, now: float | None = None) -> int:
        self._registered = (address, bytes(data))
        return p2.ERR_NONE

    def action(self, now: float | None = None) -> int:
        if self._registered is None:
            return p2.ERR_INSTRUCTION
        self.host_write(*self._registered)
        self._registered = None
        return p2.ERR_NONE

    def clear(self, params: bytes, now: float) -> int:
        return p2.ERR_NONE

    def backup(self, params: bytes, now: float) -> int:
        return p2.ERR_NONE

    def reboot(self, now: float | None = None) -> None:
        self._registered = None

    def factory_reset(self, option: int = 0xFF, now: float | None = None) -> None:
        pass


class MemoryLine(InProcessLine):
    """A ``bus.line.Line`` of ``MemoryServo`` s that answer at once: no wire time, no waiting (the
    input kept, read and dropped as ``dummy.InProcessLine`` does)."""

    tx_ms_per_byte = 0.0

    def __init__(self, models: Mapping[int, Model], baudrate: int = 57600, latency_ms: float = 1.0,
                 device: str = "fake") -> None:
        super().__init__((), baudrate)
        self.device = device
        #: the latency the bus computes its waits with (nothing waits: every reply is in at once)
        self.effective_latency_ms = latency_ms
        self.lost = False
        self.can_reopen = True
        self.silent: set[int] = set()
        self.no_fast: set[int] = set()
        self.errors: dict[int, int] = {}
        self.fail_sync_writes = False
        #: one tuple per packet handed to ``write`` (``_call2``, ``_call1``)
        self.calls: list[tuple[Any, ...]] = []
        self.servos = {i: MemoryServo(self, model, i) for i, model in models.items()}
        listed: list[Any] = list(self.servos.values())
        protocol2 = InstructionSet(listed, time.monotonic, collections.deque(maxlen=64), collections.Counter(),
                                   collections.deque(maxlen=64))
        protocol1 = Protocol1Instructions(listed, collections.Counter(), time.monotonic)
        #: per protocol, by the header its packets start with (Protocol 2.0's first: 1.0's is its prefix):
        #: the parser, the instruction set, the call tuples and the sync write's code
        self._protocols: list[tuple[bytes, Any, Any, Any, int]] = [
            (p2.HEADER, p2.PacketParser(), protocol2, _call2, p2.SYNC_WRITE),
            (p1.HEADER, Protocol1Parser(), protocol1, _call1, p1.SYNC_WRITE)]

    @property
    def is_open(self) -> bool:
        return self._open and not self.lost

    def open(self) -> None:
        if not self.can_reopen:
            raise BusError(f"{self.device} not found: the device is gone (the test's can_reopen)")
        self._open = True
        self.lost = False

    def write(self, packet: bytes) -> None:
        """Note each whole packet in ``calls`` and let the servos execute it; a sync write with
        ``fail_sync_writes`` raises what the serial port's write raises when the adapter is gone."""
        _, parser, instructions, call_of, sync_write = next(side for side in self._protocols
                                                            if packet.startswith(side[0]))
        for instruction in parser.feed(packet):
            self.calls.append(call_of(instruction))
            if self.fail_sync_writes and instruction.instruction == sync_write:
                raise serial.SerialException("write failed: [Errno 5] Input/output error")
            for _delay, status in instructions.execute(instruction):
                self._input += status


def _call2(packet: p2.Packet) -> tuple[Any, ...]:
    """A Protocol 2.0 instruction packet as a call tuple: ``("ping", id)`` (a broadcast one: ID 254),
    ``("read", id, address, size)``, ``("write", id, address, data)``, ``("reboot", id)``,
    ``("sync_read", address, length, ids, fast)``, ``("sync_write", address, length, {id: data})``,
    ``("bulk_read", {id: (address, size)}, fast)``, ``("bulk_write", {id: (address, data)})``; any
    other ``(name, id)`` and its parameters if it has any."""
    inst, dxl_id, prm = packet.instruction, packet.packet_id, packet.params
    if inst in (p2.READ, p2.WRITE, p2.REG_WRITE):
        address = p2.u16(prm)
        tail: tuple[Any, ...] = (p2.u16(prm, 2),) if inst == p2.READ else (bytes(prm[2:]),)
        return (p2.INSTRUCTION_NAMES[inst], dxl_id, address) + tail
    if inst in (p2.SYNC_READ, p2.FAST_SYNC_READ):
        return ("sync_read", p2.u16(prm), p2.u16(prm, 2), tuple(prm[4:]), inst == p2.FAST_SYNC_READ)
    if inst == p2.SYNC_WRITE:
        address, length = p2.u16(prm), p2.u16(prm, 2)
        return ("sync_write", address, length, {prm[k]: bytes(prm[k + 1:k + 1 + length])
                                                for k in range(4, len(prm), 1 + length)})
    if inst in (p2.BULK_READ, p2.FAST_BULK_READ):
        return ("bulk_read", {prm[k]: (p2.u16(prm, k + 1), p2.u16(prm, k + 3)) for k in range(0, len(prm), 5)},
                inst == p2.FAST_BULK_READ)
    if inst == p2.BULK_WRITE:
        writes, k = {}, 0
        while k + 5 <= len(prm):
            size = p2.u16(prm, k + 3)
            writes[prm[k]] = (p2.u16(prm, k + 1), bytes(prm[k + 5:k + 5 + size]))
            k += 5 + size
        return ("bulk_write", writes)
    name = p2.INSTRUCTION_NAMES.get(inst, f"0x{inst:02X}")
    return (name, dxl_id) + ((bytes(prm),) if prm and inst != p2.PING else ())


def _call1(packet: p2.Packet) -> tuple[Any, ...]:
    """A Protocol 1.0 instruction packet as a call tuple, in the shapes of ``_call2`` but for its ping:
    ``("ping1", id)``."""
    inst, dxl_id, prm = packet.instruction, packet.packet_id, packet.params
    if inst == p1.PING:
        return ("ping1", dxl_id)
    if inst == p1.READ:
        return ("read", dxl_id, prm[0], prm[1])
    if inst in (p1.WRITE, p1.REG_WRITE):
        return (p1.INSTRUCTION_NAMES[inst], dxl_id, prm[0], bytes(prm[1:]))
    if inst == p1.SYNC_WRITE:
        address, length = prm[0], prm[1]
        return ("sync_write", address, length, {prm[k]: bytes(prm[k + 1:k + 1 + length])
                                                for k in range(2, len(prm), 1 + length)})
    if inst == p1.BULK_READ:
        return ("bulk_read", {prm[k + 1]: (prm[k + 2], prm[k]) for k in range(1, len(prm) - 2, 3)}, False)
    name = p1.INSTRUCTION_NAMES.get(inst & 0xFF, f"0x{inst:02X}")
    return (name, dxl_id) + ((bytes(prm),) if prm else ())
