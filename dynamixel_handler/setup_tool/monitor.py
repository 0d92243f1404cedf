"""monitor: a live table of the servos (position, velocity, current, temperature, voltage, mode,
torque, errors) refreshed several times a second, for checking a bus without ROS. On a terminal it
is a rich live table and ``q`` quits (stdin in cbreak mode); piped, ``--count N`` prints N
refreshes as plain text. An ID asked for that does not answer has a row saying so, and is looked
for again every few seconds at the rates of the servos shown: plugged in later, it joins the table."""
from __future__ import annotations

import argparse
import contextlib
import os
import select
import sys
import time
from typing import Any, Iterator, Protocol, Sequence

from rich.live import Live

from .context import Context
from .errors import BadArguments, StepFailed
from .find import Placed
from .output import Output, plain_table, rich_table
from .plot import check_writable, draw, parse_items, series_of
from .samples import CsvLog, sample
from .values import number

__all__ = ["COLUMNS", "monitor", "prepare", "row", "show"]

COLUMNS = ["ID", "model", "position", "velocity", "current", "temp", "voltage", "mode", "torque", "errors"]
#: (column, sample key, unit)
_SHOWN = (("position", "position", "deg"), ("velocity", "velocity", "deg/s"), ("current", "current", "mA"),
          ("temp", "temp", "degC"), ("voltage", "voltage", "V"))
#: seconds between two looks for the IDs asked for that did not answer
LOOK_AGAIN_S = 2.0


def row(sample: dict[str, Any]) -> tuple[list[object], bool]:
    """One table row and whether the servo has something wrong (no reply, hardware error)."""
    row: list[object] = [sample["id"], sample["model"]]
    if not sample["reply"]:
        return row + ["no reply", "", "", "", "", sample["mode"], "", ""], True
    for _, key, unit in _SHOWN:
        value = sample.get(key)
        row.append(f"{number(value, 4 if abs(value) >= 1 else 2)} {unit}" if isinstance(value, float) else "-")
    errors = sample["errors"]
    row += [sample["mode"], "on" if sample["torque"] else "off", ",".join(errors) or "-"]
    return row, bool(errors)


def _servos(ctx: Context, ids: list[int] | None) -> tuple[list[tuple[Placed, str]], list[int]]:
    """The servos to watch (every one on the bus when no IDs are given) with their mode, and the IDs
    that answer nowhere (said, and looked for again while the table runs)."""
    found = ctx.servos(ids)
    return [_with_mode(ctx, placed) for placed in found.placed], found.missing


def _with_mode(ctx: Context, placed: Placed) -> tuple[Placed, str]:
    servo = ctx.at(placed)
    mode = servo.mode() or ("?" if servo.model.has("operating_mode") else "-")
    return placed, mode


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


class _Refresh:
    """One refresh: every servo sampled at its rate, logged (``--log``) and kept (``--plot``, JSON)."""

    def __init__(self, ctx: Context, servos: list[tuple[Placed, str]], missing: list[int], log: CsvLog | None) -> None:
        self.ctx, self.servos, self.log = ctx, servos, log
        #: IDs asked for that have not answered yet, and where to look for them
        self.missing = list(missing)
        self.rates = sorted({placed.baudrate for placed, _ in servos}) or ctx.search.rates()
        self.snapshots: list[list[dict[str, Any]]] = []
        self.timed: list[tuple[float, dict[str, Any]]] = []
        self.start = time.monotonic()
        self._look_at = self.start + LOOK_AGAIN_S

    def __call__(self) -> tuple[list[list[object]], list[str | None]]:
        at = time.monotonic()
        if self.missing and at >= self._look_at:
            self._look_again(at)
        samples = [sample(self.ctx.at(placed), placed.baudrate, mode) for placed, mode in self.servos]
        self.snapshots.append(samples)
        self.timed += [(at - self.start, s) for s in samples]
        if self.log is not None:
            self.log.write(at, samples)
        rows = [row(s) for s in samples]
        absent = [[dxl_id, "-", "not found", "", "", "", "", "", "", ""] for dxl_id in self.missing]
        return [r for r, _ in rows] + absent, ["red" if bad else None for _, bad in rows] + ["red"] * len(absent)

    def _look_again(self, now: float) -> None:
        for placed in self.ctx.search.again(self.missing, self.rates):
            self.servos.append(_with_mode(self.ctx, placed))
            self.missing.remove(placed.dxl_id)
        self.servos.sort(key=lambda s: s[0].dxl_id)
        self._look_at = now + LOOK_AGAIN_S


class Table(Protocol):
    """A refresh source: called for each refresh's rows; what it kept."""

    missing: list[int]
    snapshots: list[list[dict[str, Any]]]
    timed: list[tuple[float, dict[str, Any]]]

    @property
    def servos(self) -> Sequence[Any]: ...

    def __call__(self) -> tuple[list[list[object]], list[str | None]]: ...


def _printed(out: Output, table: Table, title: str, count: int, period: float) -> None:
    """``count`` refreshes printed one after the other (a rich table, plain columns when piped)."""
    for k in range(count):
        rows, styles = table()
        if out.console is not None:
            out.console.print(rich_table(title, COLUMNS, rows, styles))
        elif not out.as_json:
            print(plain_table(COLUMNS, rows), file=out.stream, flush=True)
            print("", file=out.stream, flush=True)
        if k + 1 < count:
            time.sleep(period)


def _saved(out: Output, table: Table, log: str | None, plot: tuple[str, list[str]] | None) -> None:
    if log is not None:
        out.say(f"{len(table.snapshots)} refresh(es) of {len(table.servos)} servo(s) logged to {log}")
    if plot is not None:
        draw(series_of(table.timed), plot[1], plot[0], f"monitor: {', '.join(plot[1])}")
        out.say(f"plot of {', '.join(plot[1])} saved to {plot[0]}")


def _plot_args(args: argparse.Namespace) -> tuple[str, list[str]] | None:
    if not args.plot:
        return None
    if len(args.plot) > 2:
        raise BadArguments(f"--plot takes FILE.svg and at most one list of items, not {len(args.plot)} words")
    items = parse_items(args.plot[1] if len(args.plot) > 1 else None)
    check_writable(args.plot[0], "--plot")
    return args.plot[0], items


def prepare(args: argparse.Namespace) -> tuple[tuple[str, list[str]] | None, CsvLog | None]:
    """``--plot`` and ``--log`` checked (before any servo is looked for); the log opened."""
    plot = _plot_args(args)
    if args.log:
        check_writable(args.log, "--log")
    return plot, CsvLog(args.log) if args.log else None


def monitor(ctx: Context, args: argparse.Namespace) -> None:
    plot, log = prepare(args)
    try:
        servos, missing = _servos(ctx, args.ids)
    except BaseException:
        if log is not None:
            log.close()
        raise
    rates = sorted({placed.baudrate for placed, _ in servos})
    show(ctx.out, args, _Refresh(ctx, servos, missing, log), f"{ctx.bus.device} at {', '.join(map(str, rates))} bps "
         "(q quits)", log, plot)


def show(out: Output, args: argparse.Namespace, table: Table, title: str, log: CsvLog | None,
         plot: tuple[str, list[str]] | None) -> None:
    """The refreshes of ``table``: a live table on a terminal (q quits), else ``--count`` printed."""
    period = 1.0 / max(0.2, min(args.rate, 50.0))
    live = out.human and args.count is None and sys.stdin.isatty() and out.svg is None
    try:
        if live:
            with _keys(), Live(rich_table(title, COLUMNS, *table()), console=out.console, auto_refresh=False) as view:
                while not _quit_pressed(period):
                    view.update(rich_table(title, COLUMNS, *table()), refresh=True)
        else:
            _printed(out, table, title, args.count or 1, period)
    finally:
        if log is not None:
            log.close()
        out.document.update(refreshes=table.snapshots, missing=table.missing)
    _saved(out, table, args.log, plot)
    if table.missing:
        raise StepFailed(f"{len(table.missing)} of {len(table.missing) + len(table.servos)} servo(s) not found (ID "
                         f"{', '.join(map(str, table.missing))}); the others were monitored")
