"""The baseline: the benchmark cycle written directly against ``dynamixel_sdk``, nothing else.

Run as its own process (like the node), so it competes for the CPU the same way:

    python bench/sdk_baseline.py DEVICE --ids 1-12 --baudrate 1000000 --latency-ms 1 --seconds 2 [--fast]

prints one JSON line with the achieved cycle rate, the period statistics and the CPU it used.

One cycle is what a minimal SDK program would do every control period: ``GroupSyncWrite`` of Goal
Position (116, 4 bytes) to every servo, then ``GroupSyncRead.txRxPacket()`` (or ``fastSyncRead()``
with ``--fast``) of Present Current + Velocity + Position (126, 10 bytes) and ``getData`` of the
three items of every servo. No unit conversion, no publishing.

Fairness: the SDK computes its reply timeout with a hard-coded 16 ms latency timer
(``(bytes * byte_time) + 2 * 16 + 2`` ms). The timeout only matters when a reply is missing, which
does not happen on the virtual bus, but the baseline uses the same rule as the handler's bus
layer, ``2 * latency_timer + bytes * byte_time + 2`` ms, with the same latency timer. The SDK's
busy-polling receive (``readPort`` in a tight loop on a non-blocking port) is left as it is: it is
what users of the SDK get, and it costs one CPU core while waiting.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, GroupSyncWrite, PacketHandler, PortHandler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import Periods, cpu_seconds  # noqa: E402
from wire import GOAL_ADDRESS, GOAL_LENGTH, PRESENT_ADDRESS, PRESENT_LENGTH  # noqa: E402


class FairPort(PortHandler):
    """PortHandler whose reply timeout uses the configured latency timer instead of 16 ms."""

    def __init__(self, port_name: str, latency_timer_ms: float) -> None:
        super().__init__(port_name)
        self.latency_timer_ms = latency_timer_ms

    def setPacketTimeout(self, packet_length: int) -> None:  # noqa: N802 (SDK name)
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + 2.0 * self.latency_timer_ms + 2.0


def run(device: str, ids: list[int], baudrate: int, latency_timer_ms: float, fast: bool, seconds: float,
        warmup_s: float = 0.2) -> dict:
    port = FairPort(device, latency_timer_ms)
    if not port.openPort() or not port.setBaudRate(baudrate):
        raise SystemExit(f"cannot open {device} at {baudrate} bps")
    ph = PacketHandler(2.0)
    reader = GroupSyncRead(port, ph, PRESENT_ADDRESS, PRESENT_LENGTH)
    for i in ids:
        reader.addParam(i)
    writer = GroupSyncWrite(port, ph, GOAL_ADDRESS, GOAL_LENGTH)
    goals = [(1024 + k).to_bytes(4, "little") for k in range(2000)]
    times: list[float] = []
    failures = loops = 0
    start = time.monotonic()
    measuring_from = start + warmup_s
    end = measuring_from + seconds
    cpu0 = None
    now = start
    while now < end:
        if cpu0 is None and now >= measuring_from:
            cpu0 = cpu_seconds(os.getpid())
            measuring_from = now
        writer.clearParam()
        goal = goals[loops % len(goals)]
        for i in ids:
            writer.addParam(i, goal)
        writer.txPacket()
        result = reader.fastSyncRead() if fast else reader.txRxPacket()
        if result != COMM_SUCCESS:
            failures += 1
        for i in ids:
            reader.getData(i, 126, 2)
            reader.getData(i, 128, 4)
            reader.getData(i, 132, 4)
        loops += 1
        now = time.monotonic()
        if now >= measuring_from and cpu0 is not None:
            times.append(now)
    window = times[-1] - measuring_from if times else seconds
    cpu = cpu_seconds(os.getpid()) - (cpu0 or 0.0)
    port.closePort()
    periods = Periods.of([measuring_from] + times, window)
    return {"rate_hz": (len(times)) / window, "mean_s": periods.mean_s, "p99_s": periods.p99_s,
            "cpu_percent": 100.0 * cpu / window, "failures": failures, "loops": len(times)}


def parse_ids(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(t) for t in text.split(",")]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("device")
    ap.add_argument("--ids", default="1-12", help="e.g. 1-12 or 1,2,3")
    ap.add_argument("--baudrate", type=int, default=1_000_000)
    ap.add_argument("--latency-ms", type=float, default=1.0, help="latency timer used in the reply timeout")
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--fast", action="store_true", help="Fast Sync Read instead of Sync Read")
    a = ap.parse_args(argv)
    print(json.dumps(run(a.device, parse_ids(a.ids), a.baudrate, a.latency_ms, a.fast, a.seconds)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
