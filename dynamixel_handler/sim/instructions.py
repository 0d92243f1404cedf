"""What the servos of the virtual bus do with each Protocol 2.0 instruction packet.

``InstructionSet`` finds the servos that hear a packet (their ID, Secondary ID or broadcast;
alive, at the line speed the host set, speaking Protocol 2.0), lets them execute it and collects
their status packets with each servo's Return Delay Time, as the Status Return Level allows.
"""

from __future__ import annotations

import collections
from typing import Callable

from ..protocol import servo as p
from ..protocol.servo import LoggedInstruction
from .faults import Replies
from .servo import VirtualServo

READ_INSTRUCTIONS = (p.READ, p.SYNC_READ, p.FAST_SYNC_READ, p.BULK_READ, p.FAST_BULK_READ)
# Instructions every hearing servo acts on when broadcast, whether its ID is listed or not.
_BROADCAST_TO_ALL = (p.PING, p.ACTION, p.REBOOT, p.FACTORY_RESET, p.CLEAR)
FACTORY_RESET_OPTIONS = (0x01, 0x02, 0xFF)

#: the protocol these packets are (a servo hears them when it answers this protocol)
PROTOCOL = 2

Refusal = tuple[float, int, int, bytes, int]
"""A write a servo refused: (time, id, address, data, error code)."""


class InstructionSet:
    """The instruction set of a bus of virtual servos: ``execute(packet)`` gives the replies.
    ``servos`` is the bus's list (changed in place by the bus); every packet is appended to
    ``log``, every refused write to ``refused``. ``line_bps``: the host's line speed of the
    packet at hand (None: every servo hears it, whatever its Baud Rate)."""

    def __init__(self, servos: list[VirtualServo], clock: Callable[[], float],
                 log: collections.deque[LoggedInstruction], stats: collections.Counter[str],
                 refused: collections.deque[Refusal]) -> None:
        self._servos = servos
        self.clock = clock
        self._log = log
        self.stats = stats
        self.refused = refused
        self.line_bps: int | None = None

    def _hearing(self, packet_id: int) -> list[VirtualServo]:
        """Servos that hear a packet for ``packet_id``, in ID order (broadcast: all). A servo
        that answers Protocol 1.0 (its family's, or Protocol Type 1) ignores Protocol 2.0 packets."""
        alive = [s for s in self._servos if not s.silent and s.protocol == PROTOCOL and s.hears(self.line_bps)]
        if packet_id == p.BROADCAST_ID:
            return sorted(alive, key=lambda s: s.id)
        return [s for s in alive if s.id == packet_id]

    def _secondary(self, packet_id: int) -> list[VirtualServo]:
        return [s for s in self._servos if not s.silent and s.protocol == PROTOCOL and s.hears(self.line_bps)
                and s.model.has("secondary_id") and s.id != packet_id and s.registers.peek("secondary_id") == packet_id]

    def execute(self, packet: p.Packet) -> Replies:
        now = self.clock()
        inst, pid = packet.instruction, packet.packet_id
        self.stats["instructions"] += 1
        handler = _HANDLERS.get(inst)
        entry = p.describe(packet, now)
        self._log.append(entry)
        targets = set(entry.ids) if pid == p.BROADCAST_ID and entry.ids else None
        for servo in self._hearing(pid):
            if targets is None or servo.id in targets or inst in _BROADCAST_TO_ALL:
                servo.note_instruction(now)
        if handler is None:
            return [(s.return_delay_s, p.build_status(s.id, s.error_flags(p.ERR_INSTRUCTION)))
                    for s in self._hearing(pid) if pid != p.BROADCAST_ID and s.status_return_level == 2]
        return handler(self, packet, now)

    def _status(self, servo: VirtualServo, inst: int, error: int, data: bytes = b"",
                broadcast: bool = False, before: tuple[int, int] | None = None) -> Replies:
        """The servo's reply, if its Status Return Level gives one. ``before``: (ID, level) the
        servo had when the packet arrived — a write of ID or Status Return Level is answered
        as the servo was addressed, the new value counts from the next packet."""
        servo_id, level = before or (servo.id, servo.status_return_level)
        if inst != p.PING:
            if broadcast and inst not in READ_INSTRUCTIONS:
                return []
            if level == 0 or (level == 1 and inst not in READ_INSTRUCTIONS):
                return []
        return [(servo.return_delay_s, p.build_status(servo_id, servo.error_flags(error), data))]

    # ------------------------------------------------------------------ one servo
    def _do_ping(self, pk: p.Packet, now: float) -> Replies:
        out = []
        for s in self._hearing(pk.packet_id):
            info = p.p16(s.registers.peek("model_number")) + bytes([s.registers.peek("firmware_version")])
            out += self._status(s, p.PING, p.ERR_NONE, info)
        return out

    def _do_read(self, pk: p.Packet, now: float) -> Replies:
        if pk.packet_id == p.BROADCAST_ID:
            return []
        out = []
        for s in self._hearing(pk.packet_id):
            if len(pk.params) != 4:
                out += self._status(s, p.READ, p.ERR_DATA_LENGTH)
                continue
            error, data = s.host_read(p.u16(pk.params), p.u16(pk.params, 2), now)
            out += self._status(s, p.READ, error, data)
        return out

    def _host_write(self, servo: VirtualServo, address: int, data: bytes, now: float) -> int:
        """A write to one servo; refused ones (range, limit, access...) are kept in ``refused``."""
        error = servo.host_write(address, data, now)
        if error & 0x7F:
            self.refused.append((now, servo.id, address, bytes(data), error & 0x7F))
        return error

    def _do_write(self, pk: p.Packet, now: float) -> Replies:
        out = []
        broadcast = pk.packet_id == p.BROADCAST_ID
        servos = self._hearing(pk.packet_id)
        quiet = self._secondary(pk.packet_id) if not broadcast else []
        for s in servos + quiet:
            before = (s.id, s.status_return_level)
            if len(pk.params) < 3:
                error = p.ERR_DATA_LENGTH
            elif pk.instruction == p.WRITE:
                error = self._host_write(s, p.u16(pk.params), pk.params[2:], now)
            else:
                error = s.reg_write(p.u16(pk.params), pk.params[2:], now)
            if s in servos:
                out += self._status(s, pk.instruction, error, broadcast=broadcast, before=before)
        return out

    def _do_simple(self, pk: p.Packet, now: float) -> Replies:
        """Action, Reboot, Clear, Control Table Backup and Factory Reset."""
        out = []
        inst = pk.instruction
        broadcast = pk.packet_id == p.BROADCAST_ID
        servos = self._hearing(pk.packet_id)
        quiet = self._secondary(pk.packet_id) if inst == p.ACTION and not broadcast else []
        for s in servos + quiet:
            error = _simple_error(s, pk, now)
            if error is None:
                continue  # the e-Manual: reset-all is refused on broadcast
            if s in servos:
                out += self._status(s, inst, error, broadcast=broadcast)
            if inst == p.REBOOT:
                s.reboot(now)
            elif inst == p.FACTORY_RESET and error == p.ERR_NONE:
                s.factory_reset(pk.params[0] if pk.params else 0xFF, now)
        return out

    # ------------------------------------------------------------------ many servos
    def _do_group_read(self, pk: p.Packet, now: float) -> Replies:
        requests = _requests_of(pk)
        if pk.packet_id != p.BROADCAST_ID or requests is None:
            return []
        if pk.instruction in (p.FAST_SYNC_READ, p.FAST_BULK_READ):
            return self._fast_read(requests, now)
        out = []
        for dev_id, address, length in requests:
            for s in self._hearing(dev_id):
                error, data = s.host_read(address, length, now)
                out += self._status(s, pk.instruction, error, data)
        return out

    def _fast_read(self, requests: list[tuple[int, int, int]], now: float) -> Replies:
        """One status packet for all: each device's segment in turn, the chain stopping at a
        device that does not answer."""
        segments, delay = [], 0.0
        for dev_id, address, length in requests:
            hearing = [s for s in self._hearing(dev_id) if s.supports_fast_read and s.status_return_level >= 1]
            if not hearing:
                break
            s = hearing[0]
            error, data = s.host_read(address, length, now)
            data = data if len(data) == length else bytes(length)
            segments.append((s.error_flags(error), s.id, data))
            delay += s.return_delay_s
        if not segments:
            return []
        chain = sum(4 + length for _, _, length in requests)
        return [(delay, p.build_fast_status(segments, chain))]

    def _do_group_write(self, pk: p.Packet, now: float) -> Replies:
        if pk.packet_id != p.BROADCAST_ID:
            return []
        for dev_id, address, data in _writes_of(pk):
            for s in self._hearing(dev_id):
                self._host_write(s, address, data, now)
        return []


def _simple_error(servo: VirtualServo, pk: p.Packet, now: float) -> int | None:
    """Run Action, Clear or Backup on one servo and return its error; Reboot and Factory Reset
    only answer here (they act after the reply). None: the servo ignores the packet."""
    inst = pk.instruction
    if inst == p.ACTION:
        return servo.action(now)
    if inst == p.BACKUP:
        return servo.backup(pk.params, now)
    if inst == p.CLEAR:
        return servo.clear(pk.params, now)
    if inst == p.REBOOT:
        return p.ERR_NONE
    option = pk.params[0] if pk.params else 0xFF  # factory reset
    if pk.packet_id == p.BROADCAST_ID and option == 0xFF:
        return None
    return p.ERR_NONE if option in FACTORY_RESET_OPTIONS else p.ERR_DATA_RANGE


def _requests_of(pk: p.Packet) -> list[tuple[int, int, int]] | None:
    """(id, address, length) per requested device of a sync/bulk read, in packet order."""
    prm = pk.params
    if pk.instruction in (p.SYNC_READ, p.FAST_SYNC_READ):
        if len(prm) < 5:
            return None
        address, length = p.u16(prm), p.u16(prm, 2)
        return [(i, address, length) for i in prm[4:]]
    if len(prm) % 5 or not prm:
        return None
    return [(prm[k], p.u16(prm, k + 1), p.u16(prm, k + 3)) for k in range(0, len(prm), 5)]


def _writes_of(pk: p.Packet) -> list[tuple[int, int, bytes]]:
    """(id, address, data) per device of a Sync or Bulk Write, in packet order; a device whose
    data the packet cuts short is left out, and so is everything after it."""
    prm = pk.params
    out = []
    if pk.instruction == p.SYNC_WRITE:
        if len(prm) < 4:
            return []
        address, length = p.u16(prm), p.u16(prm, 2)
        k = 4
        while k + 1 + length <= len(prm):
            out.append((prm[k], address, bytes(prm[k + 1:k + 1 + length])))
            k += 1 + length
        return out
    k = 0
    while k + 5 <= len(prm):
        dev_id, address, length = prm[k], p.u16(prm, k + 1), p.u16(prm, k + 3)
        out.append((dev_id, address, bytes(prm[k + 5:k + 5 + length])))
        k += 5 + length
    return out


_HANDLERS: dict[int, Callable[[InstructionSet, p.Packet, float], Replies]] = {
    p.PING: InstructionSet._do_ping,
    p.READ: InstructionSet._do_read,
    p.WRITE: InstructionSet._do_write,
    p.REG_WRITE: InstructionSet._do_write,
    p.ACTION: InstructionSet._do_simple,
    p.FACTORY_RESET: InstructionSet._do_simple,
    p.REBOOT: InstructionSet._do_simple,
    p.CLEAR: InstructionSet._do_simple,
    p.BACKUP: InstructionSet._do_simple,
    p.SYNC_READ: InstructionSet._do_group_read,
    p.FAST_SYNC_READ: InstructionSet._do_group_read,
    p.BULK_READ: InstructionSet._do_group_read,
    p.FAST_BULK_READ: InstructionSet._do_group_read,
    p.SYNC_WRITE: InstructionSet._do_group_write,
    p.BULK_WRITE: InstructionSet._do_group_write,
}
