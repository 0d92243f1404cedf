"""Graphs for tuning without a desktop: items over time, the goal (dashed) against the present value
(solid) for each servo, one panel per item, saved as an SVG picture. From ``monitor --plot FILE.svg
[ITEMS]`` at its end, or from a ``monitor --log`` CSV with the ``plot`` verb (no bus needed)."""
from __future__ import annotations

import argparse
import csv
import os
import stat
from typing import Any, Sequence

from .errors import BadArguments, StepFailed, cut_path
from .samples import FIELDS, CsvLog

__all__ = ["ITEMS", "parse_items", "check_writable", "draw", "plot", "series_of"]

#: the items a plot may show: name -> (present key, goal key or None, unit)
ITEMS: dict[str, tuple[str, str | None, str]] = {
    "position": ("position", "goal_position", "deg"), "velocity": ("velocity", "goal_velocity", "deg/s"),
    "current": ("current", "goal_current", "mA"), "pwm": ("pwm", "goal_pwm", "%"),
    "temperature": ("temp", None, "degC"), "voltage": ("voltage", None, "V"),
}
DEFAULT_ITEMS = ["position", "velocity", "current"]

#: (time [s], value) per (servo ID, key)
Series = dict[tuple[int, str], list[tuple[float, float]]]


def parse_items(text: str | None) -> list[str]:
    """``position,current`` -> the items to draw (the default when None); BadArguments otherwise."""
    if text is None:
        return list(DEFAULT_ITEMS)
    names = [n.strip().lower().replace("present_", "").replace("goal_", "") for n in text.split(",") if n.strip()]
    names = ["temperature" if n in ("temp", "present_temperature") else n for n in names]
    unknown = [n for n in names if n not in ITEMS]
    if unknown or not names:
        shown = unknown[0][:40] if unknown else text[:40]
        raise BadArguments(f"cannot plot '{shown}': the items are {', '.join(ITEMS)} (comma separated)")
    return names


def check_writable(path: str, option: str) -> None:
    """One line (exit 1) when ``path`` cannot be written, before the bus is used (a file that was
    not there is not left behind)."""
    existed = os.path.lexists(path)
    if existed and os.path.exists(path) and not stat.S_ISREG(os.stat(path).st_mode):
        raise StepFailed(f"{option} {cut_path(path)}: not a regular file (a FIFO, a device or a folder): refused")
    try:
        with open(path, "a", encoding="utf-8"):
            pass
    except OSError as exc:
        raise StepFailed(f"{option} {cut_path(path)}: cannot write it: {exc.strerror}") from None
    if not existed:
        os.unlink(path)


#: a goal is drawn only where the servo's mode follows it (a velocity-mode servo ignores its goal position)
_GOAL_MODES = {"goal_position": ("position", "ex_position", "cur_position"), "goal_velocity": ("velocity",),
               "goal_current": ("current", "cur_position"), "goal_pwm": ("pwm",)}


def series_of(samples: Sequence[tuple[float, dict[str, Any]]]) -> Series:
    """(time, sample) pairs -> the series of every key with a value (goals where the mode follows them)."""
    series: Series = {}
    for at, s in samples:
        for key, _, _ in FIELDS:
            value = s.get(key)
            if key in _GOAL_MODES and s.get("mode") not in _GOAL_MODES[key]:
                continue
            if isinstance(value, (int, float)):
                series.setdefault((int(s["id"]), key), []).append((at, float(value)))
    return series


def read_csv(path: str) -> Series:
    """The series of a ``monitor --log`` file; BadArguments when it is not one."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO would wait for a writer
            raise BadArguments(f"{cut_path(path)} is not a regular file (a FIFO, a device or a folder): refused")
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
    except OSError as exc:
        raise BadArguments(f"cannot read {cut_path(path)}: {exc.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise BadArguments(f"{cut_path(path)} is not a monitor --log file: {str(exc)[:80]}") from None
    if not rows or "time_s" not in rows[0] or "id" not in rows[0]:
        raise BadArguments(f"{cut_path(path)} is not a monitor --log file (no time_s and id columns)")
    columns = {key: col for (key, _, _), col in zip(FIELDS, CsvLog.COLUMNS[8:])}
    samples = []
    for row in rows:
        try:
            at = float(row["time_s"])
            sample: dict[str, Any] = {"id": int(row["id"]), "mode": row.get("mode")}
            sample.update({key: float(row[col]) for key, col in columns.items() if row.get(col)})
        except (TypeError, ValueError):
            continue
        samples.append((at, sample))
    return series_of(samples)


def draw(series: Series, items: Sequence[str], path: str, title: str) -> None:
    """The SVG: one panel per item, each servo a colour, goal dashed, present solid."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    ids = sorted({dxl_id for dxl_id, _ in series})
    if not ids:
        raise StepFailed(f"nothing to plot in {cut_path(path)}: no servo answered")
    figure, axes = pyplot.subplots(len(items), 1, figsize=(9, 2.4 * len(items) + 0.6), sharex=True, squeeze=False)
    colours = pyplot.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, name in zip(axes[:, 0], items):
        present, goal, unit = ITEMS[name]
        for k, dxl_id in enumerate(ids):
            colour = colours[k % len(colours)]
            for key, style, width, label in ((goal, "--", 2.4, f"ID {dxl_id} goal"), (present, "-", 1.2, f"ID {dxl_id}")):
                points = series.get((dxl_id, key)) if key else None
                if points:
                    axis.plot([t for t, _ in points], [v for _, v in points], style, color=colour, label=label,
                              linewidth=width, alpha=0.55 if key == goal else 1.0)
        axis.set_ylabel(f"{name} [{unit}]")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="upper right", fontsize="small")
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle(title)
    figure.tight_layout()
    try:
        figure.savefig(path, format="svg")
    except OSError as exc:
        raise StepFailed(f"cannot write {cut_path(path)}: {exc.strerror}") from None
    finally:
        pyplot.close(figure)


def plot(args: argparse.Namespace) -> dict[str, Any]:
    """The ``plot`` verb: a ``monitor --log`` CSV drawn as an SVG (no bus)."""
    items = parse_items(args.items)
    series = read_csv(args.csv)
    check_writable(args.svg_file, "plot")
    draw(series, items, args.svg_file, f"{os.path.basename(args.csv)}: {', '.join(items)}")
    return {"file": args.svg_file, "items": items, "ids": sorted({i for i, _ in series})}
