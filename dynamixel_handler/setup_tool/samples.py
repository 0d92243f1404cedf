"""One refresh of ``monitor``: each servo's present and goal values in units, read in one read per
servo, and the CSV rows ``monitor --log`` writes (a timestamp and one row per servo per refresh)."""
from __future__ import annotations

import csv
import datetime
from typing import IO, Any

from ..bus.ops import Read
from ..control_table import Model
from .errors import StepFailed
from .items import to_unit
from .scan import _errors
from .servo import Servo
from .values import servo_doc

__all__ = ["FIELDS", "sample", "sample_items", "filled", "CsvLog"]

#: (key, item, unit): what a refresh reads, in the order of the CSV's columns
FIELDS = (("position", "present_position", "deg"), ("goal_position", "goal_position", "deg"),
          ("velocity", "present_velocity", "deg/s"), ("goal_velocity", "goal_velocity", "deg/s"),
          ("current", "present_current", "mA"), ("goal_current", "goal_current", "mA"),
          ("pwm", "present_pwm", "%"), ("goal_pwm", "goal_pwm", "%"),
          ("temp", "present_temperature", "degC"), ("voltage", "present_input_voltage", "V"))
_FLAGS = ("torque_enable", "hardware_error_status")


def sample(servo: Servo, baudrate: int, mode: str) -> dict[str, Any]:
    """One servo's values in units (None where the model lacks one); ``reply: False`` if silent."""
    model = servo.model
    names = sample_items(model)
    doc = servo_doc(servo.dxl_id, model, baudrate, mode=mode, reply=False)
    items = sorted((model.item(n) for n in names), key=lambda i: i.address)
    if not items:
        return doc
    first = items[0].address
    got = servo.execute(Read(servo.dxl_id, first, items[-1].address + items[-1].size - first, protocol=servo.protocol))
    if got.value is None:
        return doc
    return filled(servo, doc, {i.name: i.from_bytes(bytes(got.value[i.address - first:][:i.size])) for i in items})


def sample_items(model: Model) -> list[str]:
    """The items a sample of a servo of ``model`` reads."""
    return [n for _, n, _ in FIELDS if model.has(n)] + [n for n in _FLAGS if model.has(n)]


def filled(servo: Servo, doc: dict[str, Any], raw: dict[str, int]) -> dict[str, Any]:
    """``doc`` (a sample without a reply) with the values ``raw`` (item -> register value) read."""
    model = servo.model
    doc["reply"] = True
    for key, name, _ in FIELDS:
        doc[key] = to_unit(model, model.item(name), raw[name]) if name in raw else None
    doc["torque"] = raw.get("torque_enable") == 1
    # Protocol 1.0: the error bits of the status packet (no Hardware Error Status register)
    doc["errors"] = _errors(raw.get("hardware_error_status", 0)) + servo.status_errors()
    return doc


def _cell(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4f}".rstrip("0").rstrip(".")
    return str(value)


class CsvLog:
    """``monitor --log FILE.csv``: a header, then one row per servo per refresh, each with the
    seconds since the first refresh and the UTC time."""

    COLUMNS = ["time_s", "utc", "id", "model", "baudrate", "mode", "torque", "errors"] + \
        [f"{key}_{unit.replace('/', '_')}" for key, _, unit in FIELDS] + ["reply"]

    def __init__(self, path: str) -> None:
        self.path = path
        try:
            self._file: IO[str] = open(path, "w", newline="", encoding="utf-8")
        except OSError as exc:
            raise StepFailed(f"--log {path}: cannot write it: {exc.strerror}") from None
        self._csv = csv.writer(self._file)
        self._csv.writerow(self.COLUMNS)
        self._start: float | None = None

    def write(self, at: float, samples: list[dict[str, Any]]) -> None:
        if self._start is None:
            self._start = at
        utc = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")
        for s in samples:
            row = [f"{at - self._start:.3f}", utc, s["id"], s["model"], s["baudrate"], s["mode"],
                   "" if not s["reply"] else int(bool(s.get("torque"))), ";".join(s.get("errors", []))]
            row += [_cell(s.get(key)) for key, _, _ in FIELDS] + [int(bool(s["reply"]))]
            self._csv.writerow(row)
        self._file.flush()

    def close(self) -> None:
        self._file.close()
