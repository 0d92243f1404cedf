"""A full scan of a bus: the set-up tool's ``scan`` against dynamixel_sdk's broadcastPing + ping loop.

On the virtual bus (its own process, wire timing on unless ``--no-wire-timing``), servos at three
baud rates, two of them sharing an ID, and a Protocol 1.0 AX-12A. Both scans look at every baud
rate the tool tries (9600 ... 10.5 M) and IDs 0-252:

* the tool: ``dynamixel_handler_setup scan --json`` run as a command, timed from the outside
  (process start included) and by its own figure;
* the baseline, written directly against dynamixel_sdk in this process: at each rate
  ``PacketHandler(2.0).broadcastPing`` for Protocol 2.0, then ``PacketHandler(1.0).ping`` for
  every ID (Protocol 1.0 has no broadcast ping), as a hand-written script or a scanning GUI does;
  ``--sdk-ping-loop-2`` adds a Protocol 2.0 ``ping`` of every ID too.

Prints both times, their ratio and what each found. Usage::

    python bench/bench_scan.py                      # about 2 minutes with wire timing
    python bench/bench_scan.py --protocol 2         # Protocol 2.0 only
    python bench/bench_scan.py --ids 0-20 --no-wire-timing --json out.json
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler

from dynamixel_handler.setup_tool.servo import SEARCH_ORDER
from dynamixel_handler.sim import VirtualBus

#: (ID, model, baud rate): three rates, two XM430 at ID 4 (they collide), an AX-12A (Protocol 1.0)
BUS = [(1, "XM430-W350", 57600), (2, "XL330-M288", 57600), (3, "XM540-W270", 1_000_000),
       (4, "XM430-W350", 115200), (4, "XM430-W350", 115200), (7, "AX-12A", 1_000_000),
       (10, "XC430-W150", 1_000_000)]
MODELS = {"XM430-W350": 1020, "XL330-M288": 1200, "XM540-W270": 1120, "XC430-W150": 1070, "AX-12A": 12}


def _ids(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def _state_file(folder: str) -> str:
    """The bench's bus as a ``--state`` file: each servo at its own baud rate."""
    path = os.path.join(folder, "bus.json")
    bus = VirtualBus([(sid, MODELS[name]) for sid, name, _ in BUS], wire_timing=False)
    for servo, (_, _, bps) in zip(bus.all_servos, sorted(BUS, key=lambda s: s[0])):
        values = {rate: value for value, rate in servo.baud_rates.items()}
        servo.write("baud_rate", values[bps])
    bus.save_state(path)
    bus.close()
    return path


def _start_bus(state: str, wire_timing: bool) -> tuple[subprocess.Popen, str]:
    cmd = [sys.executable, "-m", "dynamixel_handler.sim", "--quiet", "--state", state]
    proc = subprocess.Popen(cmd + ([] if wire_timing else ["--no-wire-timing"]), stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    return proc, proc.stdout.readline().strip()


def tool_scan(device: str, rates: list[int], ids: list[int], protocol: str) -> tuple[float, dict]:
    """Wall time of ``dynamixel_handler_setup scan --json`` and its JSON document."""
    cmd = [sys.executable, "-m", "dynamixel_handler.setup_tool", "scan", "--device", device, "--json",
           "--baud", ",".join(map(str, rates)), "--ids", f"{ids[0]}-{ids[-1]}", "--protocol", protocol]
    started = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    took = time.perf_counter() - started
    if done.returncode not in (0, 1):
        raise SystemExit(f"the tool failed ({done.returncode}): {done.stderr.strip()}")
    return took, json.loads(done.stdout)


def sdk_scan(device: str, rates: list[int], ids: list[int], protocol: str,
             ping_loop_2: bool) -> tuple[float, list[tuple[int, int, int, int]], list[int]]:
    """The baseline: seconds, [(ID, model, bps, protocol)] found and the rates the port refused."""
    port = PortHandler(device)
    ph2, ph1 = PacketHandler(2.0), PacketHandler(1.0)
    found: list[tuple[int, int, int, int]] = []
    refused: list[int] = []
    started = time.perf_counter()
    port.openPort()
    for bps in rates:
        try:
            if not port.setBaudRate(bps):
                refused.append(bps)
                continue
        except Exception:  # pyserial refuses a rate the adapter cannot do
            refused.append(bps)
            continue
        seen = set()
        if protocol in ("2", "both"):
            answered, _ = ph2.broadcastPing(port)
            for dxl_id, (model, _fw) in sorted(answered.items()):
                if dxl_id in ids:
                    found.append((dxl_id, model, bps, 2))
                    seen.add(dxl_id)
            if ping_loop_2:
                for dxl_id in ids:
                    model, result, _ = ph2.ping(port, dxl_id)
                    if result == COMM_SUCCESS and dxl_id not in seen:
                        found.append((dxl_id, model, bps, 2))
        if protocol in ("1", "both"):
            for dxl_id in ids:
                model, result, _ = ph1.ping(port, dxl_id)
                if result == COMM_SUCCESS:
                    found.append((dxl_id, model, bps, 1))
    took = time.perf_counter() - started
    port.closePort()
    return took, sorted(found), refused


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-wire-timing", action="store_true",
                    help="the virtual bus replies at once (default: the wire's real time, as hardware)")
    ap.add_argument("--protocol", choices=("2", "1", "both"), default="both")
    ap.add_argument("--ids", type=_ids, default=list(range(253)), metavar="LO-HI", help="default 0-252")
    ap.add_argument("--sdk-ping-loop-2", action="store_true",
                    help="the baseline also pings every ID in Protocol 2.0 (no broadcast ping)")
    ap.add_argument("--json", metavar="FILE", help="write the figures as JSON")
    args = ap.parse_args()
    rates = list(SEARCH_ORDER)
    wire = not args.no_wire_timing
    with tempfile.TemporaryDirectory() as folder:
        proc, device = _start_bus(_state_file(folder), wire)
        try:
            tool_s, document = tool_scan(device, rates, args.ids, args.protocol)
            sdk_s, sdk_found, refused = sdk_scan(device, rates, args.ids, args.protocol, args.sdk_ping_loop_2)
        finally:
            proc.communicate("quit\n", timeout=30)
    _report(args, wire, rates, tool_s, document, sdk_s, sdk_found, refused)
    return 0


def _report(args, wire: bool, rates: list[int], tool_s: float, document: dict, sdk_s: float,
            sdk_found: list[tuple[int, int, int, int]], refused: list[int]) -> None:
    ids = args.ids
    print(f"virtual bus: {len(BUS)} servos at 57600, 115200 and 1M bps (two at ID 4, an AX-12A at ID 7); "
          f"wire timing {'ON (real wire time and Return Delay Times)' if wire else 'OFF (replies at once)'}")
    print(f"scan: {len(rates)} baud rates ({', '.join(map(str, rates))}), IDs {ids[0]}-{ids[-1]}, "
          f"protocol {args.protocol}")
    servos = document.get("servos", [])
    tool_found = sorted((s["id"], s.get("model_number"), s["baudrate"], s["protocol"]) for s in servos)
    collided = sorted({s["id"] for s in servos if s.get("collision")})
    print(f"tool  dynamixel_handler_setup scan: {tool_s:7.1f} s wall (its own figure {document.get('seconds', 0):.1f} s); "
          f"found {len(tool_found)}: {tool_found}; collisions at IDs {collided}")
    parts = []
    if args.protocol in ("2", "both"):
        parts.append("broadcastPing" + (" + Protocol 2.0 ping loop" if args.sdk_ping_loop_2 else ""))
    if args.protocol in ("1", "both"):
        parts.append("Protocol 1.0 ping loop")
    print(f"sdk   {' + '.join(parts)}: {sdk_s:7.1f} s; found {len(sdk_found)}: {sdk_found}"
          + (f"; rates the port refused: {refused}" if refused else ""))
    print(f"ratio sdk / tool: {sdk_s / tool_s:.2f} (above 1: the tool is faster)")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"wire_timing": wire, "rates": rates, "ids": [ids[0], ids[-1]], "protocol": args.protocol,
                       "tool_s": tool_s, "tool_own_s": document.get("seconds"), "tool_found": tool_found,
                       "tool_collisions": collided, "sdk_s": sdk_s, "sdk_found": sdk_found,
                       "sdk_refused_rates": refused}, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
