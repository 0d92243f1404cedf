"""The virtual Dynamixel bus: servos behind a pseudo-terminal, speaking Protocol 2.0.

One serving thread blocks in ``select()`` on the pty master, parses instruction packets,
lets the addressed servos execute them and writes their status packets back, in the order
and (optionally) at the pace a real half-duplex bus would. Faults can be injected at any
time from another thread: silent IDs, corrupted CRCs, garbage, truncated replies, hardware
errors, or the whole adapter vanishing and coming back.

``VirtualBus`` is the public face (servos, faults, state file, log) over its parts, each an
object: ``serving.WireServer`` (the serving thread and wire timing), ``instructions.InstructionSet``
(what the servos do with each instruction) and ``faults.ReplyFaults`` (what goes wrong with replies).
"""

from __future__ import annotations

import collections
import json
import os
import random
import threading
import time
from typing import Callable, Mapping

from ..protocol import servo as p
from ..protocol.servo import LoggedInstruction
from .faults import ReplyFaults
from .instructions import InstructionSet, Refusal
from .serving import FACTORY_BAUDRATE, WireServer
from .servo import VirtualServo
from .transport import PtyPort

__all__ = ["VirtualBus", "LoggedInstruction", "FACTORY_BAUDRATE"]


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
        self._servo_bps = baudrate
        self.state_file = state_file
        self.clock = clock
        self._lock = threading.RLock()
        self._servos: list[VirtualServo] = []  # changed in place: the instruction set holds it
        self._port = PtyPort(link)
        self.stats: collections.Counter[str] = collections.Counter()
        #: writes a servo refused: (time, id, address, data, error code) — sync writes included,
        #: which get no reply on a real bus, so tests can tell what a servo rejected
        self.refused: collections.deque[Refusal] = collections.deque(maxlen=10_000)
        self._log: collections.deque[LoggedInstruction] = collections.deque(maxlen=log_size)
        self._instructions = InstructionSet(self._servos, clock, self._log, self.stats, self.refused)
        self._faults = ReplyFaults(random.Random(seed), self.stats)
        self._server = WireServer(self._port, self._lock, self._instructions, self._faults, self.stats,
                                  baudrate, latency_s, check_baudrate, wire_timing)
        for servo_id, model in (servos or {}).items():
            self.add_servo(servo_id, model)
        if state_file and os.path.exists(state_file):
            self.load_state(state_file)

    # ------------------------------------------------------------------ the wire's settings
    @property
    def baudrate(self) -> int | None:
        """Line speed the wire is timed at (None: the host's, when ``wire_timing``)."""
        return self._server.baudrate

    @baudrate.setter
    def baudrate(self, bps: int | None) -> None:
        self._server.baudrate = bps

    @property
    def latency_s(self) -> float:
        return self._server.latency_s

    @latency_s.setter
    def latency_s(self, seconds: float) -> None:
        self._server.latency_s = seconds

    @property
    def check_baudrate(self) -> bool:
        return self._server.check_baudrate

    @check_baudrate.setter
    def check_baudrate(self, on: bool) -> None:
        self._server.check_baudrate = on

    @property
    def wire_timing(self) -> bool:
        return self._server.wire_timing

    @wire_timing.setter
    def wire_timing(self, on: bool) -> None:
        self._server.wire_timing = on

    @property
    def crc_error_rate(self) -> float:
        """Share of replies whose CRC is corrupted (0..1)."""
        return self._faults.crc_error_rate

    @crc_error_rate.setter
    def crc_error_rate(self, rate: float) -> None:
        self._faults.crc_error_rate = rate

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

        Useful for tools and for inspecting replies without wire timing.
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
            self._servos.clear()
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
            self._servos[:] = [s for s in self._servos if s.id != servo_id]

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


def _set_bps(servo: VirtualServo, bps: int) -> None:
    values = {rate: v for v, rate in servo.baud_rates.items()}
    if bps not in values:
        raise ValueError(f"{servo.model.name} cannot run at {bps} bps "
                         f"(it can: {', '.join(str(b) for b in sorted(values))})")
    servo.write("baud_rate", values[bps])
