"""``monitor`` through a running handler node: each refresh one ``dynamixel/get_items`` of the
items the table shows (present values, temperature, voltage, mode, torque, errors) for every servo
watched, read by the node's loop between its steps; the same table, ``--count``, ``--log``,
``--plot`` and JSON as on the bus. Without IDs: the servos of the node's ``dynamixel/manifest``."""
from __future__ import annotations

import argparse
import time
from typing import Any, cast

from . import monitor
from .errors import StepFailed
from .node_verbs import NodeContext, NodeServo
from .samples import CsvLog, filled, sample_items
from .servo import Servo
from .values import servo_doc

__all__ = ["monitor_verb"]

#: what a servo's mode is told from
_MODE_ITEMS = ("operating_mode", "min_position_limit", "max_position_limit", "torque_control_mode_enable")


class _NodeRefresh:
    """One refresh: every servo's items in one request through the node; logged and kept."""

    def __init__(self, ctx: NodeContext, servos: list[Servo], log: CsvLog | None) -> None:
        self.ctx, self.servos, self.log = ctx, [cast(NodeServo, s) for s in servos], log
        self.missing = list(ctx.missing)
        self.snapshots: list[list[dict[str, Any]]] = []
        self.timed: list[tuple[float, dict[str, Any]]] = []
        self.start = time.monotonic()
        self.names = list(dict.fromkeys(n for s in self.servos for n in (*sample_items(s.model), *_MODE_ITEMS)
                                        if s.model.has(n)))

    def __call__(self) -> tuple[list[list[object]], list[str | None]]:
        at = time.monotonic()
        self._read()
        samples = [self._sample(s) for s in self.servos]
        self.snapshots.append(samples)
        self.timed += [(at - self.start, s) for s in samples]
        if self.log is not None:
            self.log.write(at, samples)
        rows = [monitor.row(s) for s in samples]
        absent = [[dxl_id, "-", "not handled", "", "", "", "", "", "", ""] for dxl_id in self.missing]
        return [r for r, _ in rows] + absent, ["red" if bad else None for _, bad in rows] + ["red"] * len(absent)

    def _read(self) -> None:
        """Every servo's items read through the node now (``values``; those not read left out)."""
        _, entries = self.ctx.client.get([s.dxl_id for s in self.servos], self.names)
        for s in self.servos:
            s.values = {}
        by_id = {s.dxl_id: s for s in self.servos}
        for e in entries:
            if e.raw is not None:
                by_id[e.dxl_id].values[e.item] = e.raw

    def _sample(self, servo: NodeServo) -> dict[str, Any]:
        names = sample_items(servo.model)
        mode = _mode(servo)
        doc = servo_doc(servo.dxl_id, servo.model, self.ctx.baudrate[servo.dxl_id], mode=mode, reply=False)
        if not all(n in servo.values for n in names):
            return doc  # not read (no reply to the node's reads)
        return filled(servo, doc, {n: servo.values[n] for n in names})


def _mode(servo: NodeServo) -> str:
    try:
        return servo.mode() or ("?" if servo.model.has("operating_mode") else "-")
    except StepFailed:  # an item of it not read this time
        return "?"


def monitor_verb(ctx: NodeContext, args: argparse.Namespace) -> None:
    plot, log = monitor.prepare(args)
    try:
        servos = ctx.find(args.ids if args.ids else ctx.client.handled())
    except BaseException:
        if log is not None:
            log.close()
        raise
    title = f"{ctx.device} through the running node {ctx.client.owner.node} (q quits)"
    monitor.show(ctx.out, args, _NodeRefresh(ctx, servos, log), title, log, plot)
