#!/usr/bin/env python3
"""A step response before and after tuning, on the virtual bus: docs/img/tuning_step.svg.

    python scripts/tuning_plot.py                         # factory gains against P 1600, D 4000
    python scripts/tuning_plot.py --tuned 2400,0,8000 --also none --out /tmp/step.svg

One XM430-W350 on a virtual bus, driven by the handler's own core (``Handler``, ``Commander``,
``Runner``: what the node runs, without ROS) with the node's default profiles (1000 deg/s, 6008
deg/s^2): the gains are set as a ``servos`` entry, the servo is sent to 0 deg, then to 45 deg, and
the present position the loop reads is recorded each loop. The virtual servo's clock moves 10 ms per
loop, so the traces are the same on every machine (the loop itself runs at 200 Hz of host time).
Prints, for each gain set, the time to 90 % of the step, the overshoot and the time to settle
within 0.5 deg; the picture needs matplotlib (requirements.txt).
"""
from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import dataclass

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
    VirtualBus,
)

XM430_W350 = 1020
FACTORY = (800, 0, 0)  # the XM430-W350's Position P, I, D Gains as unboxed (e-Manual)
TUNED = (1600, 0, 4000)
ALSO = ((3200, 0, 0), (200, 0, 0))  # too much P without D (overshoot), too little (slow)
SIM_STEP_S = 0.010  # the virtual servo's time per loop
STEP_DEG = 45.0


class _SimClock:
    """The virtual bus's clock, moved by the loop (``SIM_STEP_S`` a pass)."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


@dataclass
class Response:
    gains: tuple[int, int, int]
    trace: list[tuple[float, float]]  # (time since the step [s], present position [deg])

    def time_to(self, fraction: float) -> float | None:
        return next((t for t, deg in self.trace if deg >= fraction * STEP_DEG), None)

    def overshoot_deg(self) -> float:
        return max(deg for _, deg in self.trace) - STEP_DEG

    def settle_s(self, band_deg: float = 0.5) -> float | None:
        outside = [t for t, deg in self.trace if abs(deg - STEP_DEG) > band_deg]
        return None if not outside or outside[-1] >= self.trace[-1][0] else outside[-1]

    def label(self) -> str:
        p, i, d = self.gains
        return f"P {p}, I {i}, D {d}"


def step_response(gains: tuple[int, int, int], seconds: float = 1.0) -> Response:
    """The present position over ``seconds`` after a 0 -> 45 deg goal step, with ``gains`` (P, I, D)."""
    clock = _SimClock()
    sim = VirtualBus(servos={1: XM430_W350}, baudrate=1_000_000, clock=clock, wire_timing=False)
    log = logging.getLogger("tuning_plot")
    wire = DynamixelBus(sim.start(), 1_000_000, latency_timer_ms=1.0, logger=log)
    p, i, d = gains
    entry = {"position_p_gain_pulse": p, "position_i_gain_pulse": i, "position_d_gain_pulse": d}
    settings = Settings(scan=ScanSettings(min_id=1, max_id=1, expected=1, retry_times=5),
                        loop=LoopSettings(rate_hz=200.0, verbose_ratio=0), servos=(ServoSetting(1, entry),))
    handler = Handler(wire, settings, log)
    trace: list[tuple[float, float]] = []
    stepped: list[float] = []

    def states_ready(report: StepReport) -> None:  # the loop's reads of this pass are in the table
        if stepped and "position" in report.present:
            trace.append((round(clock.t - stepped[0], 6), float(handler.table.units("present_position")[0])))
        clock.t += SIM_STEP_S

    wire.open()
    try:
        handler.start()
        commander = Commander(handler)
        handler.attach(commander)
        runner = Runner(handler, wire, settings.loop.rate_hz, log=log, hooks=Hooks(states_ready=states_ready))
        commander.control("X", "position_control", [1], {"position_deg": [0.0]})
        runner.run(loops=100)  # a second of servo time to get to 0 deg and settle
        stepped.append(clock.t)
        commander.control("X", "position_control", [1], {"position_deg": [STEP_DEG]})
        runner.run(loops=100 + int(round(seconds / SIM_STEP_S)))
        if runner.failed:
            raise RuntimeError("the handler's loop gave up")
    finally:
        handler.shutdown()
        wire.close()
        sim.close()
    return Response(gains, [(t, deg) for t, deg in trace if t <= seconds + 1e-9])


def draw(responses: list[Response], path: str) -> None:
    """The SVG: the goal step (dashed) and each gain set's present position (the first two, before
    and after, bold; the others thin)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    matplotlib.rcParams["svg.hashsalt"] = "tuning_step"  # the same ids each run: a picture that did not change is not a diff
    figure, axis = pyplot.subplots(figsize=(8, 4))
    end = max(t for r in responses for t, _ in r.trace)
    axis.plot([0.0, 0.0, end], [0.0, STEP_DEG, STEP_DEG], "--", color="grey", linewidth=1.5, label="goal")
    for n, response in enumerate(responses):
        t90 = response.time_to(0.9)
        extra = f": 90 % at {t90:.2f} s, overshoot {max(0.0, response.overshoot_deg()):.1f} deg" if t90 is not None else ""
        name = ("factory: ", "tuned: ")[n] if n < 2 else ""
        axis.plot([t for t, _ in response.trace], [deg for _, deg in response.trace], linewidth=2.2 if n < 2 else 1.0,
                  linestyle="-" if n < 2 else ":", label=name + response.label() + extra)
    axis.set_xlabel("time after the goal step [s]")
    axis.set_ylabel("present position [deg]")
    axis.set_title("XM430-W350 on the virtual bus: 0 -> 45 deg, profile 1000 deg/s, 6008 deg/s²")
    axis.grid(True, alpha=0.3)
    axis.legend(loc="lower right", fontsize="small")
    figure.tight_layout()
    figure.savefig(path, metadata={"Date": None} if path.endswith(".svg") else None)  # SVG: no date (reproducible)
    pyplot.close(figure)


def _gains(text: str) -> tuple[int, int, int]:
    parts = [int(x) for x in text.split(",")]
    if len(parts) != 3:
        raise argparse.ArgumentTypeError("P,I,D: three integers")
    return parts[0], parts[1], parts[2]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/img/tuning_step.svg", help="the SVG to write")
    ap.add_argument("--before", type=_gains, default=FACTORY, help="P,I,D before (default: factory 800,0,0)")
    ap.add_argument("--tuned", type=_gains, default=TUNED, help="P,I,D after (default: 1600,0,4000)")
    ap.add_argument("--also", default=";".join(",".join(map(str, g)) for g in ALSO),
                    help="more P,I,D sets drawn thin, ';' between them, or 'none' (default: 3200,0,0;200,0,0)")
    ap.add_argument("--seconds", type=float, default=0.6, help="how long to record after the step")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="[%(levelname)s] %(message)s")
    also = [] if a.also.strip().lower() == "none" else [_gains(g) for g in a.also.split(";") if g.strip()]
    responses = [step_response(gains, a.seconds) for gains in (a.before, a.tuned, *also)]
    for r in responses:
        t90, settle = r.time_to(0.9), r.settle_s()
        settled = f"within 0.5 deg from {settle:.2f} s" if settle is not None else "not within 0.5 deg by the end"
        reached = f"90 % at {t90:.2f} s" if t90 is not None else "90 % not reached"
        print(f"{r.label()}: {reached}, overshoot {max(0.0, r.overshoot_deg()):.2f} deg, {settled}")
    draw(responses, a.out)
    print(f"written: {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
