"""The virtual bus's wire: the serving thread, the pace of a half-duplex line, and faults.

One thread blocks in ``select()`` on the pty master (and a wake-up pipe), parses instruction
packets, has the servos execute them (``ServoInstructions``) and writes their status packets
back: with wire timing, each byte at the line speed the host set, each servo's reply after its
Return Delay Time, so a client sees the timing of hardware. Fault injection (corrupted CRCs,
truncated replies, garbage) acts on the replies on their way out.
"""

from __future__ import annotations

import collections
import os
import random
import select
import threading
import time

from ..protocol import servo as p
from .instructions import Replies, ServoInstructions
from .transport import PtyPort, wait_until

INTER_BYTE_TIMEOUT_S = 0.1
FACTORY_BAUDRATE = 57600


class WireServer(ServoInstructions):
    """Serving the pty: packets in, timed status packets out."""

    baudrate: int | None
    check_baudrate: bool
    wire_timing: bool
    latency_s: float
    crc_error_rate: float
    _rng: random.Random
    _lock: threading.RLock
    _port: PtyPort
    _parser: p.PacketParser
    _garbage: bytearray
    _truncate: int
    _thread: threading.Thread | None
    _wake_r: int
    _wake_w: int
    _running: bool
    _requests: collections.deque[tuple[str, threading.Event]]
    _wire_free_at: float

    # ------------------------------------------------------------------ adapter plugged / unplugged
    def _request(self, what: str) -> None:
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
        if what == "vanish" and self._port.is_open:
            self._port.close()
            self._parser.reset()
        elif what == "reappear" and not self._port.is_open:
            self._port.open()

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
                fd = self._port.master
            fds = [self._wake_r] + ([fd] if fd is not None else [])
            timeout = INTER_BYTE_TIMEOUT_S if self._parser.pending else None
            try:
                ready, _, _ = select.select(fds, [], [], timeout)
            except (OSError, ValueError):
                continue
            if self._wake_r in ready:
                self._run_requests()
            elif not ready:
                self._parser.reset()  # a packet that stopped half-way is dropped, as a servo does
            else:
                self._receive()

    def _receive(self) -> None:
        data = self._port.read()
        if not data:
            return
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
            out = [(delay, self._apply_faults(reply)) for delay, reply in replies]
            if out and self._garbage:
                out[0] = (out[0][0], bytes(self._garbage) + out[0][1])
                self._garbage.clear()
        bps = self.baudrate or (line_bps or FACTORY_BAUDRATE if self.wire_timing else None)
        if bps:
            self._send_timed(packet, out, arrival, bps)
        else:
            for _, reply in out:
                self._port.write(reply)

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
            self._port.write(reply)
        self._wire_free_at = t

    def _apply_faults(self, reply: bytes) -> bytes:
        if self.crc_error_rate > 0 and self._rng.random() < self.crc_error_rate:
            reply = reply[:-1] + bytes([reply[-1] ^ 0x5A])
            self.stats["crc_corrupted"] += 1
        if self._truncate > 0:
            self._truncate -= 1
            reply = reply[: max(1, len(reply) // 2)]
            self.stats["truncated"] += 1
        return reply
