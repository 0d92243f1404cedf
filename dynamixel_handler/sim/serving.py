"""The virtual bus's wire: the serving thread and the pace of a half-duplex line.

One thread blocks in ``select()`` on the pty master (and a wake-up pipe), parses instruction
packets, has the servos execute them (``InstructionSet``) and writes their status packets
back: with wire timing, each byte at the line speed the host set, each servo's reply after its
Return Delay Time, so a client sees the timing of hardware. ``ReplyFaults`` spoils the replies
on their way out. The same bytes go to a Protocol 1.0 reader too (``protocol1``): each protocol's
servos hear only their own packets. Replies of servos sharing an ID collide (``collision``).
"""

from __future__ import annotations

import collections
import os
import select
import threading
import time
from typing import Any, Callable

from ..protocol import servo as p
from .collision import DEFAULT_SKEW_BYTES, overlap, status_id_1, status_id_2
from .faults import Replies, ReplyFaults
from .instructions import InstructionSet
from .protocol1 import Protocol1Instructions, Protocol1Parser
from .transport import PtyPort, wait_until

INTER_BYTE_TIMEOUT_S = 0.1
FACTORY_BAUDRATE = 57600


class WireServer:
    """Serving one pty: packets in, timed status packets out. ``lock`` is the bus's: the servos
    execute a packet under it. The wire settings are the bus's (see ``VirtualBus``)."""

    def __init__(self, port: PtyPort, lock: threading.RLock, instructions: InstructionSet, faults: ReplyFaults,
                 stats: collections.Counter[str], baudrate: int | None, latency_s: float,
                 check_baudrate: bool, wire_timing: bool,
                 instructions1: Protocol1Instructions | None = None) -> None:
        self.port = port
        self._lock = lock
        self._instructions = instructions
        self._faults = faults
        self._stats = stats
        #: line speed the wire is timed at (None: the host's, with wire_timing)
        self.baudrate = baudrate
        self.latency_s = latency_s
        self.check_baudrate = check_baudrate
        self.wire_timing = wire_timing
        self._parser = p.PacketParser()
        self._instructions1 = instructions1
        self._parser1 = Protocol1Parser()
        #: byte-times between the starts of two colliding replies (see ``collision``)
        self.collision_skew_bytes = DEFAULT_SKEW_BYTES
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = os.pipe()
        self._running = False
        self._requests: collections.deque[tuple[str, threading.Event]] = collections.deque()
        self._wire_free_at = 0.0

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> str:
        """Open the pty, start serving; returns the device path to open."""
        with self._lock:
            if self._running:
                return self.port.path  # type: ignore[return-value]
            path = self.port.open()
            self._running = True
            self._thread = threading.Thread(target=self._serve, name="dxl-virtual-bus", daemon=True)
            self._thread.start()
            return path

    def stop(self) -> None:
        with self._lock:
            if not self._running:
                self.port.close()
                return
            self._running = False
        os.write(self._wake_w, b"s")
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.port.close()
        self._thread = None

    def close(self) -> None:
        """Stop and release the wake-up pipe; the server cannot be restarted afterwards."""
        self.stop()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass

    # ------------------------------------------------------------------ adapter plugged / unplugged
    def request(self, what: str) -> None:
        """Run ``what`` ("vanish" / "reappear") on the serving thread (at once when not serving)."""
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
        if what == "vanish" and self.port.is_open:
            self.port.close()
            self._reset_parsers()
        elif what == "reappear" and not self.port.is_open:
            self.port.open()

    def _run_requests(self) -> None:
        os.read(self._wake_r, 64)
        with self._lock:
            while self._requests:
                what, done = self._requests.popleft()
                self._do(what)
                done.set()

    # ------------------------------------------------------------------ serving
    def _serve(self) -> None:
        while True:
            with self._lock:
                if not self._running:
                    return
                fd = self.port.master
            fds = [self._wake_r] + ([fd] if fd is not None else [])
            timeout = INTER_BYTE_TIMEOUT_S if self._parser.pending or self._parser1.pending else None
            try:
                ready, _, _ = select.select(fds, [], [], timeout)
            except (OSError, ValueError):
                continue
            if self._wake_r in ready:
                self._run_requests()
            elif not ready:
                self._reset_parsers()  # a packet that stopped half-way is dropped, as a servo does
            else:
                self._receive()

    def _receive(self) -> None:
        data = self.port.read()
        if not data:
            return
        arrival = time.perf_counter()
        timed = self.wire_timing or self.baudrate is not None
        line = self.port.host_baudrate() if (self.check_baudrate or timed) else None
        for packet in self._parser.feed(data):
            self._transact(packet, arrival, line, self._instructions, status_id_2)
        self._stats["crc_errors"] = self._parser.crc_errors
        if self._instructions1 is not None:
            for packet in self._parser1.feed(data):
                self._transact(packet, arrival, line, self._instructions1, status_id_1)

    def _reset_parsers(self) -> None:
        self._parser.reset()
        self._parser1.reset()

    def _transact(self, packet: Any, arrival: float, line_bps: int | None,
                  instructions: InstructionSet | Protocol1Instructions,
                  status_id: Callable[[bytes], int | None]) -> None:
        """One instruction packet carried out by ``instructions`` (its protocol's engine); the
        replies overlapped where servos share an ID (``status_id`` reads a reply's ID)."""
        with self._lock:
            instructions.line_bps = line_bps if self.check_baudrate else None
            try:
                replies = instructions.execute(packet)
            finally:
                instructions.line_bps = None
            replies = overlap(replies, self.baudrate or line_bps or FACTORY_BAUDRATE,
                              status_id, self.collision_skew_bytes)
            out = self._faults.apply(replies)
        bps = self.baudrate or (line_bps or FACTORY_BAUDRATE if self.wire_timing else None)
        if bps:
            self._send_timed(packet, out, arrival, bps)
        else:
            for _, reply in out:
                self.port.write(reply)

    def _send_timed(self, packet: p.Packet, out: Replies, arrival: float, bps: int) -> None:
        """Each reply leaves when the line would carry it: after the instruction's bytes, the
        adapter latency, the servo's Return Delay Time and the replies before it."""
        byte_s = 10.0 / bps
        start = max(arrival, self._wire_free_at)
        t = start + packet.wire_size * byte_s
        if out:
            t += self.latency_s
        for delay, reply in out:
            t += delay + len(reply) * byte_s
            wait_until(t)
            self.port.write(reply)
        self._wire_free_at = t


class WireSettings:
    """The wire's settings of a bus, kept by its ``WireServer`` and ``ReplyFaults`` (see
    ``VirtualBus`` for what each does)."""

    _server: WireServer
    _faults: ReplyFaults

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
    def collision_skew_bytes(self) -> int:
        """Byte-times between the starts of the replies of two servos at one ID (``collision``)."""
        return self._server.collision_skew_bytes

    @collision_skew_bytes.setter
    def collision_skew_bytes(self, n: int) -> None:
        self._server.collision_skew_bytes = int(n)

    @property
    def crc_error_rate(self) -> float:
        """Share of replies whose CRC is corrupted (0..1)."""
        return self._faults.crc_error_rate

    @crc_error_rate.setter
    def crc_error_rate(self, rate: float) -> None:
        self._faults.crc_error_rate = rate
