"""Loop benchmark: the node against the wire limit and against a bare dynamixel-sdk loop.

    source env.sh && python bench/bench_loop.py [--quick] [--json out.json]

For each bus (1 and 4 Mbps, adapter latency 0 and 1 ms) and each number of X servos (1, 4, 12,
30) on the virtual bus with wire timing, it measures:
- the wire limit of one cycle (``wire.py``: exact packets, bytes x 10 / baud + latency per reply);
- the bare ``dynamixel-sdk`` cycle, Sync Read and Fast Sync Read (``sdk_baseline.py``, own process);
- the node (own process) reading present current/velocity/position every loop, writing goal
  positions every loop from /dynamixel/commands/x, publishing /dynamixel/states and
  /dynamixel/debug, flat out (loop_rate 2000) and at loop_rate 100, with method/fast_read false and
  true (``node_run.py``).
Then it prints one table with the ratios node / SDK and node / wire limit, and the targets.

``--quick`` measures only the target bus (12 servos, 1 Mbps, latency 0 and 1 ms) with shorter windows.
"""
from __future__ import annotations

import argparse
import fcntl
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, fields

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def claim_domain() -> str:
    """A ROS domain no concurrent test run or benchmark uses: the same lock files as the test suite
    (one per domain, held while this process lives), searched from the top so tests rarely meet it."""
    for domain in range(100, 0, -1):
        handle = open(os.path.join(tempfile.gettempdir(), f"dynamixel_handler_test_domain_{domain}.lock"), "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        claim_domain.handle = handle  # type: ignore[attr-defined]
        return str(domain)
    return "100"


# Before rclpy is imported anywhere: discovery on this machine only, on a domain of our own.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_DOMAIN_ID"] = claim_domain()


import wire  # noqa: E402
from common import raise_priority  # noqa: E402
from node_run import Controller, NodeResult, measure_node  # noqa: E402
from sim_process import BusProcess  # noqa: E402

X_MODEL = 1020  # XM430-W350

#: the targets of the issue, evaluated on this bus
TARGET_N, TARGET_BAUD = 12, 1_000_000


@dataclass
class Row:
    baudrate: int
    latency_ms: float
    n: int
    fast_read: bool
    wire_hz: float
    sdk_hz: float = float("nan")
    sdk_cpu: float = float("nan")
    sdk_failures: int = 0
    max_: NodeResult | None = None
    at100: NodeResult | None = None

    @property
    def node_vs_sdk(self) -> float:
        return self.max_.rate_hz / self.sdk_hz if self.max_ else float("nan")

    @property
    def node_vs_wire(self) -> float:
        return self.max_.rate_hz / self.wire_hz if self.max_ else float("nan")


def sdk_run(path: str, n: int, baudrate: int, latency_s: float, fast: bool, seconds: float) -> dict:
    cmd = [sys.executable, os.path.join(HERE, "sdk_baseline.py"), path, "--ids", f"1-{n}", "--baudrate",
           str(baudrate), "--latency-ms", str(max(1.0, latency_s * 1000)), "--seconds", str(seconds)]
    if fast:
        cmd.append("--fast")
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    if done.returncode != 0:
        return {"rate_hz": float("nan"), "cpu_percent": float("nan"), "failures": -1, "error": done.stderr[-400:]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def ms(seconds: float) -> str:
    return "-" if not math.isfinite(seconds) else f"{1000 * seconds:.2f}"


def num(value: float, fmt: str = "{:.0f}") -> str:
    return "-" if not math.isfinite(value) else fmt.format(value)


def table(rows: list[Row]) -> str:
    head = ("baud  lat  N fast | wire Hz  sdk Hz | node Hz  mean ms  p99 ms  cpu% | /sdk  /wire | "
            "@100: Hz  cpu%  lat mean  lat p99 ms | bench%  others%")
    out = [head, "-" * len(head)]
    for r in rows:
        m, h = r.max_ or NodeResult(), r.at100 or NodeResult()
        out.append(
            f"{r.baudrate // 1_000_000}M {r.latency_ms:4.0f} {r.n:2d} {'yes' if r.fast_read else ' no'}  | "
            f"{r.wire_hz:7.0f} {num(r.sdk_hz):>7} | {num(m.rate_hz):>7} {ms(m.mean_s):>8} {ms(m.p99_s):>7} "
            f"{num(m.cpu_percent):>5} | {num(r.node_vs_sdk, '{:.2f}'):>4} {num(r.node_vs_wire, '{:.2f}'):>5} | "
            f"{num(h.rate_hz):>8} {num(h.cpu_percent):>5} {ms(h.latency_mean_s):>9} {ms(h.latency_p99_s):>8} | "
            f"{num(m.bench_cpu_percent):>6} {num(m.others_cpu_percent):>7}")
    return "\n".join(out)


def key(row: Row) -> tuple:
    return (row.baudrate, row.latency_ms, row.n, row.fast_read)


def _median(values: list[float]) -> float:
    finite = sorted(v for v in values if math.isfinite(v))
    if not finite:
        return float("nan")
    mid = len(finite) // 2
    return finite[mid] if len(finite) % 2 else 0.5 * (finite[mid - 1] + finite[mid])


def median_rows(rows: list[Row]) -> list[Row]:
    """One row per bus, servo count and read method: every figure the median of its runs."""
    groups: dict[tuple, list[Row]] = {}
    for row in rows:
        groups.setdefault(key(row), []).append(row)
    out = []
    for runs in groups.values():
        if len(runs) == 1:
            out.append(runs[0])
            continue
        first = runs[0]
        row = Row(first.baudrate, first.latency_ms, first.n, first.fast_read, first.wire_hz,
                  _median([r.sdk_hz for r in runs]), _median([r.sdk_cpu for r in runs]),
                  max(r.sdk_failures for r in runs))
        for attr in ("max_", "at100"):
            results = [getattr(r, attr) for r in runs if getattr(r, attr) is not None]
            if results:
                merged = NodeResult()
                for f in fields(NodeResult):
                    values = [getattr(x, f.name) for x in results]
                    if all(isinstance(v, (int, float)) for v in values):
                        setattr(merged, f.name, type(values[0])(_median([float(v) for v in values])))
                merged.error = "; ".join(x.error for x in results if x.error)
                setattr(row, attr, merged)
        # the ratios of the median row are those of the median rates, not medians of ratios
        out.append(row)
    return out


def targets(rows: list[Row]) -> list[str]:
    lines = []
    for r in rows:
        if r.n != TARGET_N or r.baudrate != TARGET_BAUD or not r.max_ or not r.at100:
            continue
        tag = f"12 servos 1 Mbps latency {r.latency_ms:g} ms, fast_read {'true' if r.fast_read else 'false'}"
        checks = [("node rate >= 0.9 x SDK rate", r.node_vs_sdk >= 0.9, f"{r.node_vs_sdk:.2f}")]
        if r.fast_read:
            checks.append(("node rate >= 0.85 x wire limit", r.node_vs_wire >= 0.85, f"{r.node_vs_wire:.2f}"))
        checks.append(("CPU <= 25 % at loop_rate 100", r.at100.cpu_percent <= 25.0, f"{r.at100.cpu_percent:.0f} %"))
        for label, res in (("flat out", r.max_), ("loop_rate 100", r.at100)):
            bound = res.mean_s + 0.001
            checks.append((f"latency p99 <= period + 1 ms ({label})", res.latency_p99_s <= bound,
                           f"{ms(res.latency_p99_s)} vs {ms(bound)} ms"))
        # the performance issue's targets at loop_rate 100 (12 servos, 1 Mbps)
        c = wire.cycle(r.n, r.baudrate, r.latency_ms / 1000, r.fast_read)
        read_s = (c.read_bytes + c.reply_bytes) * 10.0 / c.baudrate + c.latency_s
        checks += [("CPU <= 10 % at loop_rate 100", r.at100.cpu_percent <= 10.0, f"{r.at100.cpu_percent:.0f} %"),
                   ("latency mean <= 1.0 ms at loop_rate 100", r.at100.latency_mean_s <= 0.001,
                    f"{ms(r.at100.latency_mean_s)} ms"),
                   ("latency p99 <= one read + 1 ms at loop_rate 100", r.at100.latency_p99_s <= read_s + 0.001,
                    f"{ms(r.at100.latency_p99_s)} vs {ms(read_s + 0.001)} ms")]
        for label, ok, value in checks:
            lines.append(f"  [{'met' if ok else 'NOT met'}] {tag}: {label}: {value}")
    under = [r for r in rows if r.max_ and not r.node_vs_sdk >= 0.9]
    lines.append(f"  every row node rate >= 0.9 x SDK (same read): {len(rows) - len(under)} of {len(rows)} rows"
                 + "".join(f"\n    under: {r.baudrate // 1_000_000}M lat {r.latency_ms:g} N={r.n} "
                           f"fast={'yes' if r.fast_read else 'no'}: {r.node_vs_sdk:.2f}" for r in under))
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="target bus only (12 servos, 1 Mbps), short windows")
    ap.add_argument("--window", type=float, default=None, help="seconds measured per node run")
    ap.add_argument("--sdk-window", type=float, default=None, help="seconds measured per SDK run")
    ap.add_argument("--n", default=None, help="servo counts, e.g. 12 or 1,4,12,30")
    ap.add_argument("--baud", default=None, help="baud rates, e.g. 1000000,4000000")
    ap.add_argument("--latency-ms", default=None, help="adapter latencies, e.g. 0,1")
    ap.add_argument("--repeat", type=int, default=1,
                    help="measure each row this many times; the table and the targets show the median of the runs")
    ap.add_argument("--json", default=None, help="also write every figure to this file")
    ap.add_argument("--command", choices=("bundle", "control", "none"), default="bundle",
                    help="goal commands: /dynamixel/commands/x (default), /dynamixel/command/x/position_control, "
                         "or none (then the node only reads and publishes)")
    ap.add_argument("--no-boost", action="store_true", help="keep normal priority (default: nice -10 when allowed)")
    ap.add_argument("--exact-physics", action="store_true",
                    help="refresh the virtual servos at every instruction (slow: then the simulator, not the wire, "
                         "limits every contender)")
    a = ap.parse_args(argv)
    counts = [int(x) for x in (a.n or ("12" if a.quick else "1,4,12,30")).split(",")]
    bauds = [int(x) for x in (a.baud or ("1000000" if a.quick else "1000000,4000000")).split(",")]
    latencies = [float(x) / 1000 for x in (a.latency_ms or "0,1").split(",")]
    window = a.window or (1.5 if a.quick else 1.2)
    sdk_window = a.sdk_window or (1.0 if a.quick else 0.6)

    nice = "normal priority" if a.no_boost else raise_priority()
    physics = "exact servo physics" if a.exact_physics else "servo motion refreshed every 5 ms"
    import rclpy
    rclpy.init()
    controller = Controller(a.command)
    rows: list[Row] = []
    began = time.monotonic()
    print(f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, bench/node/SDK at {nice}, {physics}, commands: {a.command}, load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    try:
        for baudrate in bauds:
            for latency_s in latencies:
                for n in counts:
                    # the virtual bus runs in a process of its own, as hardware would (sim_process.py)
                    sim = BusProcess(a.exact_physics, servos={i: X_MODEL for i in range(1, n + 1)},
                                     baudrate=baudrate, latency_s=latency_s)
                    path, priority = sim.path, sim.setup
                    for i in range(1, n + 1):
                        sim.write(i, "return_delay_time", 0)  # as the node sets it (default/return_delay_time)
                    try:
                        for fast, rep in [(f, k) for k in range(a.repeat) for f in (False, True)]:
                            row = Row(baudrate, latency_s * 1000, n, fast, wire.cycle(n, baudrate, latency_s, fast).rate_hz)
                            sdk = sdk_run(path, n, baudrate, latency_s, fast, sdk_window)
                            row.sdk_hz, row.sdk_cpu, row.sdk_failures = sdk["rate_hz"], sdk["cpu_percent"], sdk["failures"]
                            for loop_rate in (2000, 100):
                                sim.clear_log()
                                res = measure_node(sim, controller, n, baudrate, latency_s, loop_rate, fast, window)
                                if res.error:
                                    print(f"  node run failed ({res.error}):\n    " + "\n    ".join(res.log_tail),
                                          file=sys.stderr, flush=True)
                                if loop_rate == 100:
                                    row.at100 = res
                                else:
                                    row.max_ = res
                            rows.append(row)
                            print(f"[{time.monotonic() - began:5.0f}s] ({priority}) "
                                  + (f"run {rep + 1}/{a.repeat}: " if a.repeat > 1 else "")
                                  + f"{baudrate // 1_000_000} Mbps, latency "
                                  f"{latency_s * 1000:g} ms, N={n:2d}, fast_read={fast}: wire {row.wire_hz:.0f} Hz, "
                                  f"sdk {row.sdk_hz:.0f} Hz, node {row.max_.rate_hz:.0f} Hz (node start-up {row.max_.startup_s:.1f} s)",
                                  flush=True)
                    finally:
                        sim.close()
    finally:
        controller.close()
        rclpy.try_shutdown()
    shown = median_rows(rows)
    print()
    if a.repeat > 1:
        print(f"Median of {a.repeat} runs per row (each run's ratios: /sdk, /wire, cpu% at 100):")
        for row in shown:
            runs = [r for r in rows if key(r) == key(row)]
            print(f"  {row.baudrate // 1_000_000}M lat {row.latency_ms:g} N={row.n:2d} fast={'yes' if row.fast_read else 'no '}: "
                  + "  ".join(f"{r.node_vs_sdk:.2f} {r.node_vs_wire:.2f} {num(r.at100.cpu_percent if r.at100 else math.nan)}%"
                              for r in runs))
        print()
    print(table(shown))
    print()
    print("Targets" + (f" (medians of {a.repeat} runs)" if a.repeat > 1 else "") + ":")
    print("\n".join(targets(shown)) or "  (the target bus was not measured)")
    print(f"\ntotal {time.monotonic() - began:.0f} s, load average now {os.getloadavg()[0]:.2f}")
    if a.json:
        with open(a.json, "w") as handle:
            json.dump([asdict(r) for r in rows], handle, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
