"""The virtual Dynamixel bus: servos behind a pseudo-terminal, speaking Protocol 2.0.

One serving thread blocks in ``select()`` on the pty master, parses instruction packets,
lets the addressed servos execute them and writes their status packets back, in the order
and (optionally) at the pace a real half-duplex bus would. Faults can be injected at any
time from another thread: silent IDs, corrupted CRCs, garbage, truncated replies, hardware
errors, or the whole adapter vanishing and coming back.
"""

from __future__ import annotations

import collections
import json
import os
import random
import select
import threading
import time
from typing import Callable, Mapping

from ..protocol import servo as p
from ..protocol.servo import LoggedInstruction
from .servo import VirtualServo
from .transport import PtyPort, wait_until

INTER_BYTE_TIMEOUT_S = 0.1
READ_INSTRUCTIONS = (p.READ, p.SYNC_READ, p.FAST_SYNC_READ, p.BULK_READ, p.FAST_BULK_READ)


FACTORY_BAUDRATE = 57600


class VirtualBus:
    """A bus of virtual servos on a pty. ``servos`` maps ID -> model number.

    By default the servos are as unboxed: factory values, Baud Rate 57600 (1 Mbps on the XM335),
    and they behave as on a real bus:

    * ``check_baudrate`` (default on): a servo hears only packets sent while the host's port is
      set to the speed of its Baud Rate register (read from the pty, see
      ``PtyPort.host_baudrate``); a write to Baud Rate takes effect after its status reply.
      Off: servos answer at any host baud rate.
    * ``wire_timing`` (default on): each transaction takes (instruction + reply bytes) * 10 /
      line speed plus ``latency_s`` plus the servos' Return Delay Time, the line speed being the
      one the host set on its port. Off: replies as fast as possible (tests that need speed).

    ``baudrate`` puts every servo at that speed (its Baud Rate register) and times the wire at it
    even with ``wire_timing`` off; setting the attribute later times the wire from then on.
    ``state_file``: the servos' EEPROM is loaded from it (when it exists) and ``save_state``
    writes it, so ID, baud rate and limits survive a restart as on hardware.
    """

    def __init__(self, servos: Mapping[int, int] | None = None, baudrate: int | None = None,
                 latency_s: float = 0.0, link: str | None = None,
                 clock: Callable[[], float] = time.monotonic, seed: int | None = None,
                 log_size: int = 100_000, check_baudrate: bool = True, wire_timing: bool = True,
                 state_file: str | None = None) -> None:
        self.baudrate = baudrate
        self._servo_bps = baudrate
        self.check_baudrate = check_baudrate
        self.wire_timing = wire_timing
        self.state_file = state_file
        self._line_bps: int | None = None  # host line speed of the packet being executed
        self.latency_s = latency_s
        self.clock = clock
        self.crc_error_rate = 0.0
        self._rng = random.Random(seed)
        self._lock = threading.RLock()
        self._servos: list[VirtualServo] = []
        self._log: collections.deque[LoggedInstruction] = collections.deque(maxlen=log_size)
        self._port = PtyPort(link)
        self._parser = p.PacketParser()
        self._garbage = bytearray()
        self._truncate = 0
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = os.pipe()
        self._running = False
        self._requests: collections.deque = collections.deque()
        self._wire_free_at = 0.0
        self.stats = collections.Counter()
        #: writes a servo refused: (time, id, address, data, error code) — sync writes included,
        #: which get no reply on a real bus, so tests can tell what a servo rejected
        self.refused: collections.deque = collections.deque(maxlen=10_000)
        for servo_id, model in (servos or {}).items():
            self.add_servo(servo_id, model)
        if state_file and os.path.exists(state_file):
            self.load_state(state_file)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> str:
        """Open the pty, start serving; returns the device path to open."""
        with self._lock:
            if self._running:
                return self.path  # type: ignore[return-value]
            path = self._port.open()
            self._running = True
            self._thread = threading.Thread(target=self._serve, name="dxl-virtual-bus", daemon=True)
            self._thread.start()
            return path

    def stop(self) -> None:
        with self._lock:
            if not self._running:
                self._port.close()
                return
            self._running = False
        os.write(self._wake_w, b"s")
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._port.close()
        self._thread = None

    def close(self) -> None:
        """Stop and release the wake-up pipe; the bus cannot be restarted afterwards."""
        self.stop()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> "VirtualBus":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def path(self) -> str | None:
        return self._port.path

    # ------------------------------------------------------------------ servos
    def add_servo(self, servo_id: int, model_number: int) -> VirtualServo:
        with self._lock:
            servo = VirtualServo(int(model_number), int(servo_id), self.clock)
            if self._servo_bps is not None:
                _set_bps(servo, self._servo_bps)
            self._pair(servo)
            self._servos.append(servo)
            return servo

    def _pair(self, servo: VirtualServo) -> None:
        """A dual servo (2XL430, 2XC430) is two IDs sharing one Baud Rate: each one added is
        paired with the first unpaired one of its model, in the order they were added."""
        if not servo.model.name.startswith("2X"):
            return
        for other in self._servos:
            if other.model.number == servo.model.number and other.partner is None:
                servo.partner, other.partner = other, servo
                servo.write("baud_rate", other.read("baud_rate"))
                return

    def set_baudrate(self, bps: int) -> None:
        """Put every servo at ``bps`` (its Baud Rate register, as if configured earlier) and the
        servos added later too; wire timing is left as it is."""
        with self._lock:
            for servo in self._servos:
                _set_bps(servo, bps)
            self._servo_bps = bps

    # ------------------------------------------------------------------ state file
    def save_state(self, path: str | None = None) -> None:
        """Write every servo's EEPROM (and control-table backup) to ``path`` (default: the
        ``state_file``) as JSON, atomically."""
        path = path or self.state_file
        if not path:
            return
        with self._lock:
            data = {"servos": [s.state() for s in sorted(self._servos, key=lambda s: s.id)]}
            for s in self._servos:
                s.eeprom_changed = False
        tmp = f"{path}.{os.getpid()}.tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1)
        os.replace(tmp, path)

    def load_state(self, path: str) -> None:
        """Replace the servos by those saved in ``path`` (model, EEPROM, backup), powered up."""
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        with self._lock:
            servos = []
            for entry in data["servos"]:
                servo = VirtualServo(int(entry["model"]), 1, self.clock)
                servo.load_state(entry, self.clock())
                servos.append(servo)
            self._servos = []
            for servo in servos:
                self._pair(servo)
                self._servos.append(servo)

    @property
    def eeprom_changed(self) -> bool:
        """True when a servo's EEPROM changed since the last ``save_state``."""
        with self._lock:
            return any(s.eeprom_changed for s in self._servos)

    def remove_servo(self, servo_id: int) -> None:
        with self._lock:
            self._servos = [s for s in self._servos if s.id != servo_id]

    def servo(self, servo_id: int) -> VirtualServo:
        with self._lock:
            for s in self._servos:
                if s.id == servo_id:
                    return s
        raise KeyError(f"no virtual servo with ID {servo_id}")

    @property
    def servos(self) -> dict[int, VirtualServo]:
        with self._lock:
            return {s.id: s for s in sorted(self._servos, key=lambda s: s.id)}

    # ------------------------------------------------------------------ faults
    def set_silent(self, servo_id: int, silent: bool = True) -> None:
        """The servo stops hearing and answering (cable cut) or comes back."""
        self.servo(servo_id).silent = bool(silent)

    def inject_garbage(self, nbytes: int) -> None:
        """Noise bytes sent just before the next reply (never 0xFF, so never a header)."""
        with self._lock:
            self._garbage += bytes(self._rng.randrange(0, 0xFF) for _ in range(nbytes))

    def truncate_next(self, n: int = 1) -> None:
        """Cut the next ``n`` status packets short (only their first half goes out)."""
        with self._lock:
            self._truncate += n

    def set_hardware_error(self, servo_id: int, bits: int) -> None:
        with self._lock:
            self.servo(servo_id).set_hardware_error(bits)

    def vanish(self) -> None:
        """Unplug the adapter: close the pty master (hosts get I/O errors), drop the link."""
        self._request("vanish")

    def reappear(self) -> str:
        """Plug back in: a new pty (and the link repointed to it); returns the device path."""
        self._request("reappear")
        return self.path  # type: ignore[return-value]

    @property
    def vanished(self) -> bool:
        return not self._port.is_open

    def _request(self, what: str) -> None:
        with self._lock:
            running = self._running and self._thread is not None \
                and self._thread is not threading.current_thread()
            if not running:
                self._do(what)
                return
            done = threading.Event()
            self._requests.append((what, done))
        os.write(self._wake_w, b"r")
        done.wait(timeout=2.0)

    def _do(self, what: str) -> None:
        if what == "vanish" and self._port.is_open:
            self._port.close()
            self._parser.reset()
        elif what == "reappear" and not self._port.is_open:
            self._port.open()

    # ------------------------------------------------------------------ log
    @property
    def log(self) -> list[LoggedInstruction]:
        with self._lock:
            return list(self._log)

    def clear_log(self) -> None:
        with self._lock:
            self._log.clear()

    # ------------------------------------------------------------------ serving
    def _serve(self) -> None:
        while True:
            with self._lock:
                if not self._running:
                    return
                fd = self._port.master
            fds = [self._wake_r] + ([fd] if fd is not None else [])
            timeout = INTER_BYTE_TIMEOUT_S if self._parser.pending else None
            try:
                ready, _, _ = select.select(fds, [], [], timeout)
            except (OSError, ValueError):
                continue
            if self._wake_r in ready:
                os.read(self._wake_r, 64)
                with self._lock:
                    while self._requests:
                        what, done = self._requests.popleft()
                        self._do(what)
                        done.set()
                continue
            if not ready:
                self._parser.reset()  # a packet that stopped half-way is dropped, as a servo does
                continue
            data = self._port.read()
            if not data:
                continue
            arrival = time.perf_counter()
            timed = self.wire_timing or self.baudrate is not None
            line = self._port.host_baudrate() if (self.check_baudrate or timed) else None
            for packet in self._parser.feed(data):
                self._transact(packet, arrival, line)
            self.stats["crc_errors"] = self._parser.crc_errors

    def feed(self, data: bytes) -> list[bytes]:
        """Process raw instruction bytes without the pty; returns the status packets.

        Useful for tools and for inspecting replies without wire timing.
        """
        replies: list[bytes] = []
        for packet in p.PacketParser().feed(data):
            with self._lock:
                replies += [reply for _, reply in self._execute(packet)]
        return replies

    def _transact(self, packet: p.Packet, arrival: float, line_bps: int | None = None) -> None:
        with self._lock:
            self._line_bps = line_bps if self.check_baudrate else None
            try:
                replies = self._execute(packet)
            finally:
                self._line_bps = None
            out = []
            for delay, reply in replies:
                reply = self._apply_faults(reply)
                out.append((delay, reply))
            if out and self._garbage:
                out[0] = (out[0][0], bytes(self._garbage) + out[0][1])
                self._garbage.clear()
        bps = self.baudrate or (line_bps or FACTORY_BAUDRATE if self.wire_timing else None)
        if bps:
            byte_s = 10.0 / bps
            start = max(arrival, self._wire_free_at)
            t = start + packet.wire_size * byte_s
            if out:
                t += self.latency_s
            for delay, reply in out:
                t += delay + len(reply) * byte_s
                wait_until(t)
                self._port.write(reply)
            self._wire_free_at = t
        else:
            for _, reply in out:
                self._port.write(reply)

    def _apply_faults(self, reply: bytes) -> bytes:
        if self.crc_error_rate > 0 and self._rng.random() < self.crc_error_rate:
            reply = reply[:-1] + bytes([reply[-1] ^ 0x5A])
            self.stats["crc_corrupted"] += 1
        if self._truncate > 0:
            self._truncate -= 1
            reply = reply[: max(1, len(reply) // 2)]
            self.stats["truncated"] += 1
        return reply

    # ------------------------------------------------------------------ instructions
    def _hearing(self, packet_id: int) -> list[VirtualServo]:
        """Servos that hear a packet for ``packet_id``, in ID order (broadcast: all). A servo
        set to Protocol 1.0 (Protocol Type 1) ignores Protocol 2.0 packets."""
        alive = [s for s in self._servos if not s.silent and self._on_line_speed(s) and s.speaks_protocol_2]
        if packet_id == p.BROADCAST_ID:
            return sorted(alive, key=lambda s: s.id)
        return [s for s in alive if s.id == packet_id]

    def _secondary(self, packet_id: int) -> list[VirtualServo]:
        return [s for s in self._servos if not s.silent and self._on_line_speed(s) and s.speaks_protocol_2
                and s.model.has("secondary_id") and s.id != packet_id and s._peek("secondary_id") == packet_id]

    def _on_line_speed(self, servo: VirtualServo) -> bool:
        """Whether ``servo`` can decode the packet at hand (always, unless check_baudrate)."""
        return self._line_bps is None or servo.baudrate == self._line_bps

    def _execute(self, packet: p.Packet) -> list[tuple[float, bytes]]:
        now = self.clock()
        inst, pid = packet.instruction, packet.packet_id
        self.stats["instructions"] += 1
        handler = _HANDLERS.get(inst)
        entry = p.describe(packet, now)
        self._log.append(entry)
        targets = set(entry.ids) if pid == p.BROADCAST_ID and entry.ids else None
        for servo in self._hearing(pid):
            if targets is None or servo.id in targets or inst in (p.PING, p.ACTION, p.REBOOT,
                                                                   p.FACTORY_RESET, p.CLEAR):
                servo.note_instruction(now)
        if handler is None:
            return [(s.return_delay_s, p.build_status(s.id, s.error_flags(p.ERR_INSTRUCTION)))
                    for s in self._hearing(pid) if pid != p.BROADCAST_ID and s.status_return_level == 2]
        return handler(self, packet, now)

    def _status(self, servo: VirtualServo, inst: int, error: int, data: bytes = b"",
                broadcast: bool = False, before: tuple[int, int] | None = None) -> list[tuple[float, bytes]]:
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

    def _do_ping(self, pk: p.Packet, now: float):
        out = []
        for s in self._hearing(pk.packet_id):
            info = p.p16(s._peek("model_number")) + bytes([s._peek("firmware_version")])
            out += self._status(s, p.PING, p.ERR_NONE, info)
        return out

    def _do_read(self, pk: p.Packet, now: float):
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

    def _do_write(self, pk: p.Packet, now: float):
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

    def _do_simple(self, pk: p.Packet, now: float):
        out = []
        broadcast = pk.packet_id == p.BROADCAST_ID
        servos = self._hearing(pk.packet_id)
        quiet = self._secondary(pk.packet_id) if pk.instruction == p.ACTION and not broadcast else []
        for s in servos + quiet:
            inst = pk.instruction
            if inst == p.ACTION:
                error = s.action(now)
            elif inst == p.BACKUP:
                error = s.backup(pk.params, now)
            elif inst == p.CLEAR:
                error = s.clear_multi_turn(pk.params, now)
            elif inst == p.REBOOT:
                error = p.ERR_NONE
            else:  # factory reset
                option = pk.params[0] if pk.params else 0xFF
                if broadcast and option == 0xFF:
                    continue  # the e-Manual: reset-all is refused on broadcast
                error = p.ERR_NONE if option in (0x01, 0x02, 0xFF) else p.ERR_DATA_RANGE
            if s in servos:
                out += self._status(s, inst, error, broadcast=broadcast)
            if inst == p.REBOOT:
                s.reboot(now)
            elif inst == p.FACTORY_RESET and error == p.ERR_NONE:
                s.factory_reset(pk.params[0] if pk.params else 0xFF, now)
        return out

    def _requests_of(self, pk: p.Packet) -> list[tuple[int, int, int]] | None:
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

    def _do_group_read(self, pk: p.Packet, now: float):
        requests = self._requests_of(pk)
        if pk.packet_id != p.BROADCAST_ID or requests is None:
            return []
        fast = pk.instruction in (p.FAST_SYNC_READ, p.FAST_BULK_READ)
        if not fast:
            out = []
            for dev_id, address, length in requests:
                for s in self._hearing(dev_id):
                    error, data = s.host_read(address, length, now)
                    out += self._status(s, pk.instruction, error, data)
            return out
        segments, delay = [], 0.0
        for dev_id, address, length in requests:
            hearing = [s for s in self._hearing(dev_id) if s.supports_fast_read and s.status_return_level >= 1]
            if not hearing:
                break  # the chain stops at a device that does not answer
            s = hearing[0]
            error, data = s.host_read(address, length, now)
            data = data if len(data) == length else bytes(length)
            segments.append((s.error_flags(error), s.id, data))
            delay += s.return_delay_s
        if not segments:
            return []
        chain = sum(4 + length for _, _, length in requests)
        return [(delay, p.build_fast_status(segments, chain))]

    def _do_group_write(self, pk: p.Packet, now: float):
        if pk.packet_id != p.BROADCAST_ID:
            return []
        prm = pk.params
        if pk.instruction == p.SYNC_WRITE:
            if len(prm) < 4:
                return []
            address, length = p.u16(prm), p.u16(prm, 2)
            k = 4
            while k + 1 + length <= len(prm):
                for s in self._hearing(prm[k]):
                    self._host_write(s, address, prm[k + 1:k + 1 + length], now)
                k += 1 + length
        else:
            k = 0
            while k + 5 <= len(prm):
                dev_id, address, length = prm[k], p.u16(prm, k + 1), p.u16(prm, k + 3)
                for s in self._hearing(dev_id):
                    self._host_write(s, address, prm[k + 5:k + 5 + length], now)
                k += 5 + length
        return []


def _set_bps(servo: VirtualServo, bps: int) -> None:
    values = {rate: v for v, rate in servo.baud_rates.items()}
    if bps not in values:
        raise ValueError(f"{servo.model.name} cannot run at {bps} bps "
                         f"(it can: {', '.join(str(b) for b in sorted(values))})")
    servo.write("baud_rate", values[bps])


_HANDLERS = {
    p.PING: VirtualBus._do_ping,
    p.READ: VirtualBus._do_read,
    p.WRITE: VirtualBus._do_write,
    p.REG_WRITE: VirtualBus._do_write,
    p.ACTION: VirtualBus._do_simple,
    p.FACTORY_RESET: VirtualBus._do_simple,
    p.REBOOT: VirtualBus._do_simple,
    p.CLEAR: VirtualBus._do_simple,
    p.BACKUP: VirtualBus._do_simple,
    p.SYNC_READ: VirtualBus._do_group_read,
    p.FAST_SYNC_READ: VirtualBus._do_group_read,
    p.BULK_READ: VirtualBus._do_group_read,
    p.FAST_BULK_READ: VirtualBus._do_group_read,
    p.SYNC_WRITE: VirtualBus._do_group_write,
    p.BULK_WRITE: VirtualBus._do_group_write,
}
