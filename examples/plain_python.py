#!/usr/bin/env python3
"""The handler's core without ROS: scan a bus, run the loop, send a goal, print positions.

    python examples/plain_python.py                      # its own virtual bus: two XM430 on a pty
    python examples/plain_python.py --device /dev/ttyUSB0 --baudrate 1000000 --ids 1,2
    python examples/plain_python.py --goal 45 --loops 300 --rate 100
    python examples/plain_python.py --p-gain 640 --profile-vel 60   # per-servo settings, as a servos block

The same parts as the ROS node, all from ``dynamixel_handler``: ``DynamixelBus`` (the serial
line), ``Settings`` (what the node's parameters say, typed, every field defaulting as the
parameter does), ``Handler`` (the servos on the bus), ``Commander`` (checked commands in physical
units) and ``Runner`` (the loop at the loop rate); ``ServoSetting`` is one entry of the parameters
file's ``servos`` block as a typed value (set at start-up, kept through mode changes and reboots).
The node only adds topics and services around them. Nothing here imports rclpy: the script says so at the end (``rclpy imported: False``).

Output: ``loop N: ID=deg ...`` every ``--print-every`` loops from the loop's states, then
``final: ID=deg ...``.
"""
from __future__ import annotations

import argparse
import logging
import sys
import threading

from dynamixel_handler import (
    Commander,
    DynamixelBus,
    Handler,
    Hooks,
    LoopSettings,
    Runner,
    ScanSettings,
    ServoSetting,
    Settings,
    StepReport,
)

XM430_W350 = 1020


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", help="serial device (default: a virtual bus of its own)")
    ap.add_argument("--baudrate", type=int, default=57600)
    ap.add_argument("--latency-ms", type=float, default=None,
                    help="the adapter's latency timer (default: 16, or 1 on the virtual bus)")
    ap.add_argument("--ids", default="1,2", help="IDs to look for (and to put on the virtual bus)")
    ap.add_argument("--goal", type=float, default=30.0, help="goal position of every servo [deg]")
    ap.add_argument("--loops", type=int, default=200)
    ap.add_argument("--rate", type=float, default=50.0, help="loop_rate [Hz]")
    ap.add_argument("--print-every", type=int, default=20)
    ap.add_argument("--p-gain", type=int, help="position P gain of every servo [pulse] (servos block)")
    ap.add_argument("--profile-vel", type=float, help="profile velocity of every servo [deg/s] (servos block)")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="[%(levelname)s] %(message)s")
    log = logging.getLogger("plain_python")
    ids = [int(i) for i in a.ids.split(",")]

    sim = None
    device = a.device
    if device is None:  # a virtual bus on a pseudo-terminal, served by a thread of this process
        from dynamixel_handler import VirtualBus
        sim = VirtualBus(servos={i: XM430_W350 for i in ids}, baudrate=a.baudrate)
        device = sim.start()
        print(f"virtual bus on {device}")
    latency_ms = a.latency_ms if a.latency_ms is not None else 1.0 if sim is not None else 16.0

    wire = DynamixelBus(device, a.baudrate, latency_timer_ms=latency_ms, logger=log)
    given = {"position_p_gain_pulse": a.p_gain, "profile_vel_deg_s": a.profile_vel}
    entry = {item: value for item, value in given.items() if value is not None}  # as in the parameters file
    settings = Settings(scan=ScanSettings(min_id=min(ids), max_id=max(ids), expected=len(ids), retry_times=5),
                        loop=LoopSettings(rate_hz=a.rate, verbose_ratio=0),
                        servos=tuple(ServoSetting(i, entry) for i in ids) if entry else ())
    handler = Handler(wire, settings, log)
    commander = Commander(handler)
    handler.attach(commander)  # its commands, queued by any thread, are taken by the loop thread
    wire.open()
    code = 0
    try:
        handler.start()  # scan and set up the servos (torque on)
        done = threading.Event()

        def states_ready(report: StepReport) -> None:  # on the loop thread, after each loop's reads
            if report.loop % a.print_every == 0 and "position" in report.present:
                print(f"loop {report.loop}: {positions(handler)}", flush=True)

        runner = Runner(handler, wire, settings.loop.rate_hz, log=log, hooks=Hooks(states_ready=states_ready, gave_up=done.set))
        commander.control("X", "position_control", ids, {"position_deg": [a.goal] * len(ids)})
        runner.run(loops=a.loops)  # on this thread; runner.start() would run it on a thread of its own
        print(f"final: {positions(handler)}")
        code = 1 if runner.failed else 0
    finally:
        handler.shutdown()  # stop and torque off, as term/* say
        wire.close()
        if sim is not None:
            sim.close()
    print(f"rclpy imported: {'rclpy' in sys.modules}")
    return code


def positions(handler: Handler) -> str:
    """Present position of every servo, as the loop last read it [deg]."""
    degrees = handler.table.units("present_position")
    return " ".join(f"{dxl_id}={deg:.1f}" for dxl_id, deg in zip(handler.table.ids, degrees))


if __name__ == "__main__":
    sys.exit(main())
