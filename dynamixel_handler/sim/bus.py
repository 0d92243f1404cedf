"""The virtual Dynamixel bus: servos behind a pseudo-terminal, speaking Protocol 2.0.

One serving thread blocks in ``select()`` on the pty master, parses instruction packets,
lets the addressed servos execute them and writes their status packets back, in the order
and (optionally) at the pace a real half-duplex bus would. Faults can be injected at any
time from another thread: silent IDs, corrupted CRCs, garbage, truncated replies, hardware
errors, or the whole adapter vanishing and coming back.

``VirtualBus`` is the public face (servos, faults, state file, log) over its parts, each an
object: ``serving.WireServer`` (the serving thread and wire timing), ``instructions.InstructionSet``
(what the servos do with each instruction) and ``faults.ReplyFaults`` (what goes wrong with replies).
Protocol 1.0 servos (``protocol1``) share the line, and servos sharing an ID collide (``collision``).
"""

from __future__ import annotations

import collections
import os
import random
import threading
import time
from typing import Callable, Iterable, Mapping

from dynamixel_handler.control_table import FAMILIES

from ..protocol import servo as p
from ..protocol.servo import LoggedInstruction
from .faults import ReplyFaults
from .instructions import InstructionSet, Refusal
from .plugged import AnyServo, new_servo, pair, read_state, set_bps, state_of, write_state
from .protocol1 import Protocol1Instructions
from .serving import FACTORY_BAUDRATE, WireServer, WireSettings
from .servo import VirtualServo, turn_by_hand
from .transport import PtyPort

__all__ = ["VirtualBus", "LoggedInstruction", "FACTORY_BAUDRATE", "AnyServo"]


class VirtualBus(WireSettings):
    """A bus of virtual servos on a pty. ``servos`` maps ID -> model number, or is a list of
    (ID, model number) pairs, where an ID given twice puts two servos at it (they collide, see
    ``collision``). A Protocol 1.0 model number (``protocol1.PROTOCOL1_MODELS``, the AX, RX, DX,
    EX and MX (1.0) models of ``control_table.protocol1_models()``: 12 AX-12A, 29 MX-28, 107
    EX-106+ ...) adds a servo answering only Protocol 1.0; one at the ID of a 2.0 servo does not
    collide with it (each hears only its own protocol).

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

    def __init__(self, servos: Mapping[int, int] | Iterable[tuple[int, int]] | None = None,
                 baudrate: int | None = None,
                 latency_s: float = 0.0, link: str | None = None,
                 clock: Callable[[], float] = time.monotonic, seed: int | None = None,
                 log_size: int = 100_000, check_baudrate: bool = True, wire_timing: bool = True,
                 state_file: str | None = None) -> None:
        self._servo_bps = baudrate
        self.state_file = state_file
        self.clock = clock
        self._lock = threading.RLock()
        self._servos: list[AnyServo] = []  # changed in place: the instruction sets hold it
        self._port = PtyPort(link)
        self.stats: collections.Counter[str] = collections.Counter()
        #: writes a servo refused: (time, id, address, data, error code) — sync writes included,
        #: which get no reply on a real bus, so tests can tell what a servo rejected
        self.refused: collections.deque[Refusal] = collections.deque(maxlen=10_000)
        self._log: collections.deque[LoggedInstruction] = collections.deque(maxlen=log_size)
        self._instructions = InstructionSet(self._servos, clock, self._log,  # type: ignore[arg-type]
                                            self.stats, self.refused)
        self._faults = ReplyFaults(random.Random(seed), self.stats)
        self._server = WireServer(self._port, self._lock, self._instructions, self._faults, self.stats,
                                  baudrate, latency_s, check_baudrate, wire_timing,
                                  Protocol1Instructions(self._servos, self.stats, clock))
        pairs = servos.items() if isinstance(servos, Mapping) else (servos or [])
        for servo_id, model in pairs:
            self.add_servo(servo_id, model)
        if state_file and os.path.exists(state_file):
            self.load_state(state_file)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> str:
        """Open the pty, start serving; returns the device path to open."""
        return self._server.start()

    def stop(self) -> None:
        self._server.stop()

    def close(self) -> None:
        """Stop and release the wake-up pipe; the bus cannot be restarted afterwards."""
        self._server.close()

    def __enter__(self) -> "VirtualBus":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def feed(self, data: bytes) -> list[bytes]:
        """Process raw instruction bytes without the pty; returns the status packets.

        Useful for tools and for inspecting replies without wire timing. Protocol 2.0 only, and
        the replies of servos sharing an ID come whole, one after the other (no collision).
        """
        replies: list[bytes] = []
        for packet in p.PacketParser().feed(data):
            with self._lock:
                replies += [reply for _, reply in self._instructions.execute(packet)]
        return replies

    @property
    def path(self) -> str | None:
        return self._port.path

    # ------------------------------------------------------------------ servos
    def add_servo(self, servo_id: int, model_number: int) -> AnyServo:
        """Plug a servo in (factory values, this ID). An ID already in use gets a second servo:
        both answer it and their replies collide, as on hardware."""
        with self._lock:
            servo = new_servo(int(model_number), int(servo_id), self.clock)
            servo.lock = self._lock  # a test's read does not advance the shaft beside the serving thread
            if self._servo_bps is not None:
                set_bps(servo, self._servo_bps)
            pair(servo, self._servos)
            self._servos.append(servo)
            return servo

    def set_baudrate(self, bps: int) -> None:
        """Put every servo at ``bps`` (its Baud Rate register, as if configured earlier) and the
        servos added later too; wire timing is left as it is."""
        with self._lock:
            for servo in self._servos:
                set_bps(servo, bps)
            self._servo_bps = bps

    # ------------------------------------------------------------------ state file
    def save_state(self, path: str | None = None) -> None:
        """Write every servo's EEPROM (and control-table backup) to ``path`` (default: the
        ``state_file``) as JSON, atomically."""
        path = path or self.state_file
        if path:
            with self._lock:
                data = state_of(self._servos)
            write_state(path, data)

    def load_state(self, path: str) -> None:
        """Replace the servos by those saved in ``path`` (model, EEPROM, backup), powered up."""
        servos = read_state(path, self.clock)
        with self._lock:
            for servo in servos:
                servo.lock = self._lock
            self._servos[:] = servos

    @property
    def eeprom_changed(self) -> bool:
        """True when a servo's EEPROM changed since the last ``save_state``."""
        with self._lock:
            return any(s.eeprom_changed for s in self._servos)

    def remove_servo(self, servo_id: int) -> None:
        """Unplug every servo at ``servo_id``."""
        with self._lock:
            self._servos[:] = [s for s in self._servos if s.id != servo_id]

    def unplug(self, servo: AnyServo) -> None:
        """Unplug this one servo (another at its ID stays)."""
        with self._lock:
            self._servos[:] = [s for s in self._servos if s is not servo]

    @property
    def lock(self) -> threading.RLock:
        """The lock the serving thread holds while servos execute a packet."""
        return self._lock

    def servo(self, servo_id: int) -> VirtualServo:
        """The (first added) servo of a Protocol 2.0 family at ``servo_id``; ``servos_at`` gives them
        all."""
        with self._lock:
            for s in self._servos:
                if s.id == servo_id and s.model.family in FAMILIES:
                    return s
        raise KeyError(f"no virtual servo with ID {servo_id}")

    def turn(self, servo_id: int, deg: float) -> None:
        """Turn the shaft of the (first added) servo at ``servo_id`` by hand until it reads ``deg``
        (0 deg at its middle position; ``turn`` on the command line), no instruction on the bus."""
        with self._lock:
            servos = self.servos_at(servo_id)
            if not servos:
                raise KeyError(f"no virtual servo with ID {servo_id}")
            turn_by_hand(servos[0], float(deg))

    def servos_at(self, servo_id: int) -> list[AnyServo]:
        """Every servo at ``servo_id`` (Protocol 1.0 ones included), in the order added: more
        than one means they collide."""
        with self._lock:
            return [s for s in self._servos if s.id == servo_id]

    @property
    def servos(self) -> dict[int, VirtualServo]:
        """The servos of the Protocol 2.0 families by ID (the first added, where two share an ID)."""
        with self._lock:
            out: dict[int, VirtualServo] = {}
            for s in sorted(self._servos, key=lambda s: s.id):
                if s.model.family in FAMILIES:
                    out.setdefault(s.id, s)
            return out

    @property
    def all_servos(self) -> list[AnyServo]:
        """Every servo on the bus, Protocol 1.0 ones and IDs shared included, sorted by ID."""
        with self._lock:
            return sorted(self._servos, key=lambda s: s.id)

    # ------------------------------------------------------------------ faults
    def set_silent(self, servo_id: int, silent: bool = True) -> None:
        """The servo stops hearing and answering (cable cut) or comes back (every servo at the ID)."""
        servos = self.servos_at(servo_id)
        if not servos:
            raise KeyError(f"no virtual servo with ID {servo_id}")
        for servo in servos:
            servo.silent = bool(silent)

    def inject_garbage(self, nbytes: int) -> None:
        """Noise bytes sent just before the next reply (never 0xFF, so never a header)."""
        with self._lock:
            self._faults.inject_garbage(nbytes)

    def truncate_next(self, n: int = 1) -> None:
        """Cut the next ``n`` status packets short (only their first half goes out)."""
        with self._lock:
            self._faults.truncate_next(n)

    def set_hardware_error(self, servo_id: int, bits: int) -> None:
        with self._lock:
            self.servo(servo_id).set_hardware_error(bits)

    def vanish(self) -> None:
        """Unplug the adapter: close the pty master (hosts get I/O errors), drop the link."""
        self._server.request("vanish")

    def reappear(self) -> str:
        """Plug back in: a new pty (and the link repointed to it); returns the device path."""
        self._server.request("reappear")
        return self.path  # type: ignore[return-value]

    @property
    def vanished(self) -> bool:
        return not self._port.is_open

    # ------------------------------------------------------------------ log
    @property
    def log(self) -> list[LoggedInstruction]:
        with self._lock:
            return list(self._log)

    def clear_log(self) -> None:
        with self._lock:
            self._log.clear()


