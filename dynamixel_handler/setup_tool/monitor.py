"""monitor: a live table of the servos (position, velocity, current, temperature, voltage, mode,
torque, errors) refreshed several times a second, for checking a bus without ROS. On a terminal it
is a rich live table and ``q`` quits (stdin in cbreak mode); piped, ``--count N`` prints N
refreshes as plain text."""
from __future__ import annotations

import argparse
import contextlib
import os
import select
import sys
import time
from typing import Iterator

from rich.live import Live

from .context import Context
from .errors import StepFailed
from .items import to_unit
from .output import plain_table, rich_table
from .scan import _errors
from .servo import Servo

__all__ = ["monitor"]

COLUMNS = ["ID", "model", "position", "velocity", "current", "temp", "voltage", "mode", "torque", "errors"]
#: (column, item, format)
_SHOWN = (("position", "present_position", "{:.1f} deg"), ("velocity", "present_velocity", "{:.1f} deg/s"),
          ("current", "present_current", "{:.0f} mA"), ("temp", "present_temperature", "{:.0f} degC"),
          ("voltage", "present_input_voltage", "{:.1f} V"))


def _sample(servo: Servo, mode: str) -> dict[str, object]:
    """One servo's present values in units (None where the model lacks one), or ``reply: False``."""
    model = servo.model
    names = [n for _, n, _ in _SHOWN if model.has(n)] + ["torque_enable", "hardware_error_status"]
    items = sorted((model.item(n) for n in names if model.has(n)), key=lambda i: i.address)
    if not items:
        return {"id": servo.dxl_id, "model": model.name, "mode": mode, "reply": False}
    got = servo.bus.read_result(servo.dxl_id, items[0].address, items[-1].address + items[-1].size - items[0].address)
    sample: dict[str, object] = {"id": servo.dxl_id, "model": model.name, "mode": mode, "reply": got.value is not None}
    if got.value is None:
        return sample
    raw = {i.name: int.from_bytes(got.value[i.address - items[0].address:][:i.size], "little", signed=i.signed)
           for i in items}
    for column, name, _ in _SHOWN:
        sample[column] = to_unit(model, model.item(name), raw[name]) if name in raw else None
    sample["torque"] = raw.get("torque_enable") == 1
    sample["errors"] = _errors(raw.get("hardware_error_status", 0))
    return sample


def _row(sample: dict[str, object]) -> tuple[list[object], bool]:
    """One table row and whether the servo has something wrong (no reply, hardware error)."""
    row: list[object] = [sample["id"], sample["model"]]
    if not sample["reply"]:
        return row + ["no reply", "", "", "", "", sample["mode"], "", ""], True
    for column, _, fmt in _SHOWN:
        value = sample[column]
        row.append(fmt.format(value) if isinstance(value, float) else "-")
    errors = sample["errors"]
    assert isinstance(errors, list)
    row += [sample["mode"], "on" if sample["torque"] else "off", ",".join(errors) or "-"]
    return row, bool(errors)


def _servos(ctx: Context, ids: list[int] | None) -> list[tuple[Servo, str]]:
    if not ids:
        ids = sorted(ctx.bus.scan(range(253)))
        if not ids:
            raise StepFailed(f"no servo answers at {ctx.bus.baudrate} bps on {ctx.bus.device}")
    servos = []
    for dxl_id in ids:
        servo = ctx.servo(dxl_id)
        mode = (servo.model.mode_name(servo.read("operating_mode")) or "?") if servo.model.has("operating_mode") else "-"
        servos.append((servo, mode))
    return servos


@contextlib.contextmanager
def _keys() -> Iterator[None]:
    """stdin in cbreak mode (one key at a time, no echo) while the live table runs."""
    import termios
    import tty

    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _quit_pressed(timeout: float) -> bool:
    readable, _, _ = select.select([sys.stdin], [], [], max(0.0, timeout))
    return bool(readable) and os.read(sys.stdin.fileno(), 1) in (b"q", b"Q", b"\x1b")


def monitor(ctx: Context, args: argparse.Namespace) -> None:
    servos = _servos(ctx, args.ids)
    period = 1.0 / max(0.2, min(args.rate, 50.0))
    snapshots: list[list[dict[str, object]]] = []

    def table() -> tuple[list[list[object]], list[str | None]]:
        samples = [_sample(s, mode) for s, mode in servos]
        snapshots.append(samples)
        rows = [_row(sample) for sample in samples]
        return [r for r, _ in rows], ["red" if bad else None for _, bad in rows]

    live = ctx.out.human and args.count is None and sys.stdin.isatty() and ctx.out.svg is None
    title = f"{ctx.bus.device} at {ctx.bus.baudrate} bps (q quits)"
    if not live:
        for k in range(args.count or 1):
            rows, styles = table()
            if ctx.out.console is not None:
                ctx.out.console.print(rich_table(title, COLUMNS, rows, styles))
            elif not ctx.out.as_json:
                print(plain_table(COLUMNS, rows), file=ctx.out.stream, flush=True)
                print("", file=ctx.out.stream, flush=True)
            if k + 1 < (args.count or 1):
                time.sleep(period)
    else:
        with _keys(), Live(rich_table(title, COLUMNS, *table()), console=ctx.out.console, auto_refresh=False) as view:
            while not _quit_pressed(period):
                view.update(rich_table(title, COLUMNS, *table()), refresh=True)
    ctx.out.document.update(refreshes=snapshots)
