"""The bus layer alone: sync reads as fast as possible, ``DynamixelBus`` against the SDK's ``GroupSyncRead``.

    python bench/bus_rx.py --n 1,4 --baud 1000000,4000000 --seconds 1 [--repeat 3] [--only bus|sdk]

Per bus and servo count, the virtual bus is served from a process of its own (``sim_process.py``)
and the same read (Present Current + Velocity + Position, 126, 10 bytes, of every servo; Sync Read
and Fast Sync Read) runs back to back in this process, first through ``DynamixelBus.sync_read``, then
through ``GroupSyncRead.txRxPacket()`` / ``fastSyncRead()``. No goal write, no ROS: what is left is
the host's cost of one transaction (packet out, waiting, reading and decoding the reply) on top of
its wire time. Printed: transactions a second, microseconds each, this process's CPU time per
transaction (``time.process_time``: the host's own cost, which the virtual bus's answering speed
does not change), failures, and the wire limit of one transaction (the instruction and its
replies back to back). The virtual bus answers within ~50-100 us, so at 4 Mbps both sides' rates
are bounded by it more than by the wire; the CPU per transaction is the figure to compare.
``--only bus --seconds 10`` runs one side alone, e.g. under ``strace -c -f`` or a profiler.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PacketHandler

from dynamixel_handler.bus.ops import SyncRead

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sdk_baseline import FairPort  # noqa: E402
from sim_process import BusProcess  # noqa: E402
from wire import PRESENT_ADDRESS, PRESENT_LENGTH  # noqa: E402

from dynamixel_handler.bus import DynamixelBus  # noqa: E402
from dynamixel_handler.bus.group_read import reply_bytes  # noqa: E402
from dynamixel_handler.protocol import host  # noqa: E402

X_MODEL = 1020  # XM430-W350


def wire_limit_hz(n: int, baudrate: int, fast: bool) -> float:
    ids = list(range(1, n + 1))
    inst = host.FAST_SYNC_READ if fast else host.SYNC_READ
    packet = host.build_instruction(host.BROADCAST_ID, inst, host.sync_read_params(PRESENT_ADDRESS, PRESENT_LENGTH, ids))
    wire_bytes = len(packet) + reply_bytes([(i, PRESENT_LENGTH) for i in ids], fast)
    return baudrate / 10.0 / wire_bytes


def timed(step: Callable[[], bool], seconds: float, warmup_s: float = 0.2) -> tuple[float, float, int]:
    """(transactions a second, CPU microseconds a transaction, failures) of ``step`` run back to back."""
    end = time.monotonic() + warmup_s
    while time.monotonic() < end:
        step()
    cpu0, t0 = time.process_time(), time.monotonic()
    count = failures = 0
    end = t0 + seconds
    now = t0
    while now < end:
        if not step():
            failures += 1
        count += 1
        now = time.monotonic()
    window = now - t0
    return count / window, 1e6 * (time.process_time() - cpu0) / count, failures


def ours(path: str, ids: list[int], baudrate: int, fast: bool, latency_ms: float) -> tuple[Callable[[], bool], Callable[[], None]]:
    bus = DynamixelBus(path, baudrate, latency_timer_ms=latency_ms, retry_num=0)
    bus.open()

    def step() -> bool:
        return len(bus.execute(SyncRead(PRESENT_ADDRESS, PRESENT_LENGTH, ids, fast, protocol=2)).value) == len(ids)
    return step, bus.close


def sdk(path: str, ids: list[int], baudrate: int, fast: bool, latency_ms: float) -> tuple[Callable[[], bool], Callable[[], None]]:
    port = FairPort(path, latency_ms)
    if not port.openPort() or not port.setBaudRate(baudrate):
        raise SystemExit(f"cannot open {path} at {baudrate} bps")
    reader = GroupSyncRead(port, PacketHandler(2.0), PRESENT_ADDRESS, PRESENT_LENGTH)
    for i in ids:
        reader.addParam(i)

    def step() -> bool:
        ok = (reader.fastSyncRead() if fast else reader.txRxPacket()) == COMM_SUCCESS
        for i in ids:
            reader.getData(i, PRESENT_ADDRESS, 2)
        return bool(ok)
    return step, port.closePort


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", default="1,4", help="servo counts, e.g. 1,4")
    ap.add_argument("--baud", default="1000000,4000000")
    ap.add_argument("--latency-ms", type=float, default=0.0, help="virtual adapter latency [ms]")
    ap.add_argument("--seconds", type=float, default=1.0, help="seconds measured per side and read method")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", choices=("bus", "sdk"), default=None)
    a = ap.parse_args(argv)
    sides = {"bus": ours, "sdk": sdk}
    if a.only:
        sides = {a.only: sides[a.only]}
    timer_ms = max(1.0, a.latency_ms)  # the latency timer the host configures (as the node does)
    print(f"{'baud':>4} {'N':>2} {'fast':>4} | {'wire Hz':>7} | "
          + " | ".join(f"{name:>4} Hz   us/tx  cpu us/tx" for name in sides) + (" | bus/sdk" if len(sides) == 2 else ""))
    for baudrate in [int(x) for x in a.baud.split(",")]:
        for n in [int(x) for x in a.n.split(",")]:
            ids = list(range(1, n + 1))
            sim = BusProcess(servos={i: X_MODEL for i in ids}, baudrate=baudrate, latency_s=a.latency_ms / 1000.0)
            try:
                for i in ids:
                    sim.write(i, "return_delay_time", 0)
                for _ in range(a.repeat):
                    for fast in (False, True):
                        rates = {}
                        cells = []
                        for name, make in sides.items():
                            step, close = make(sim.path, ids, baudrate, fast, timer_ms)
                            try:
                                hz, cpu, failures = timed(step, a.seconds)
                            finally:
                                close()
                            rates[name] = hz
                            cells.append(f"{hz:7.0f} {1e6 / hz:7.1f} {cpu:11.1f}" + (f" ({failures} failed)" if failures else ""))
                        ratio = f" | {rates['bus'] / rates['sdk']:7.2f}" if len(rates) == 2 else ""
                        print(f"{baudrate // 1_000_000:>3}M {n:2d} {'yes' if fast else 'no':>4} | "
                              f"{wire_limit_hz(n, baudrate, fast):7.0f} | " + " | ".join(cells) + ratio, flush=True)
            finally:
                sim.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
