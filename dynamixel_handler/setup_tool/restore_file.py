"""Reading a backup for ``restore``, with limits: a regular file only (a FIFO, a device or a folder is
refused without opening it for a read that could hang), at most ``MAX_BYTES``, YAML read by the safe
loader after a first pass that refuses anchors and aliases (a "YAML bomb" is refused at its first
alias, in well under a second) and nesting deeper than a backup has. Then every item of every
servo is checked against the model the file names (an EEPROM item of it, a whole number, the
e-Manual's range, each limit pair in order) before the bus is used at all."""
from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from typing import Any

import yaml

from ..control_table import Item, Model
from .checks import problems
from .errors import BadArguments, cut, cut_path
from .items import check_raw
from .protocol1 import any_model
from .servo import Servo

__all__ = ["Entry", "load", "kept", "present", "IDENTITY", "MAX_BYTES"]

#: the largest backup read (253 servos of the largest control table take about a tenth of it)
MAX_BYTES = 4 << 20
#: a backup nests servos: ID: eeprom: item (3 maps); a little room for comments turned maps
_MAX_DEPTH = 6
#: YAML events a backup of 253 servos has well under
_MAX_EVENTS = 200_000
#: EEPROM items that say what the servo is, never written back (the model is checked instead)
IDENTITY = ("model_number", "model_information", "firmware_version")


def kept(item: Item) -> bool:
    """The items a backup holds: EEPROM, not the identity, not the indirect addresses."""
    return item.eeprom and item.name not in IDENTITY and not item.name.startswith("indirect_")


def present(servo: Servo) -> dict[str, int]:
    """Every item a backup holds, the servo's present raw values in address order, in one read."""
    items = sorted((i for i in servo.model.items.values() if kept(i)), key=lambda i: i.address)
    data = servo.read_block(items[0], items[-1])
    first = items[0].address
    return {i.name: int.from_bytes(data[i.address - first:][:i.size], "little", signed=i.signed) for i in items}


@dataclass
class Entry:
    """One servo of a backup: where it was (ID, rate), its model and its EEPROM items (raw)."""

    dxl_id: int
    model: Model
    values: dict[str, int]

    @property
    def baudrate(self) -> int | None:
        """The rate its backed-up Baud Rate register means (None if the file has none)."""
        raw = self.values.get("baud_rate")
        return self.model.baud_rates.get(raw) if raw is not None else None

    @property
    def who(self) -> str:
        return f"ID {self.dxl_id} ({self.model.name})"


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "FIFO"), (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
                       (stat.S_ISSOCK, "socket"), (stat.S_ISDIR, "folder")):
        if test(mode):
            return name
    return "special file"


def _text(path: str) -> str:
    try:
        info = os.stat(path)
    except OSError as exc:
        raise BadArguments(f"cannot read {cut_path(path)}: {exc.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise BadArguments(f"{cut_path(path)} is a {_kind(info.st_mode)}, not a backup file: refused, nothing read")
    if info.st_size > MAX_BYTES:
        raise BadArguments(f"{cut_path(path)} has {info.st_size} bytes, more than a backup ({MAX_BYTES} at most): refused")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # never waits for a writer (a FIFO swapped in)
        with os.fdopen(fd, "rb") as handle:
            if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
                raise BadArguments(f"{cut_path(path)} is not a regular file: refused, nothing read")
            data = handle.read(MAX_BYTES + 1)
    except OSError as exc:
        raise BadArguments(f"cannot read {cut_path(path)}: {exc.strerror}") from None
    if len(data) > MAX_BYTES:
        raise BadArguments(f"{cut_path(path)} is longer than a backup ({MAX_BYTES} bytes at most): refused")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise BadArguments(f"{cut_path(path)} is not text (UTF-8): not a backup of this tool") from None


def _screen(text: str, path: str, loader: Any) -> None:
    """Refuse anchors, aliases, deep nesting and too many events before anything is built."""
    depth = events = 0
    for event in yaml.parse(text, Loader=loader):
        events += 1
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
            raise BadArguments(f"{cut_path(path)} uses YAML anchors or aliases (& *), which a backup never has: refused")
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > _MAX_DEPTH:
                raise BadArguments(f"{cut_path(path)} nests deeper than a backup ({_MAX_DEPTH} levels): refused")
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
        if events > _MAX_EVENTS:
            raise BadArguments(f"{cut_path(path)} has more entries than a backup of 253 servos: refused")


def _yaml(path: str) -> Any:
    text = _text(path)
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        _screen(text, path, loader)
        return yaml.load(text, Loader=loader)  # noqa: S506 (the safe loader: plain data only)
    except yaml.YAMLError as exc:
        raise BadArguments(f"{cut_path(path)} is not YAML: {cut(str(exc).splitlines()[0], 120)}") from None
    except (ValueError, RecursionError) as exc:  # a number too long to be one, ...
        raise BadArguments(f"{cut_path(path)} is not a backup of this tool: {cut(exc, 80)}") from None


def _values(model: Model, values: dict[Any, Any], where: str) -> tuple[dict[str, int], list[str]]:
    """The items of one servo (name -> raw) and every problem of them."""
    good: dict[str, int] = {}
    found = []
    for name, raw in values.items():
        item = model.items.get(str(name))
        if item is None or not kept(item) or not isinstance(raw, int) or isinstance(raw, bool):
            found.append(f"{where} {cut(name)}: {cut(repr(raw))} is not a raw value of an EEPROM item of {model.name}")
            continue
        try:
            check_raw(model, item, raw, where)
        except BadArguments as exc:  # a code the model does not take (a baud rate, a mode)
            found.append(str(exc))
            continue
        good[item.name] = raw
    return good, found


def _entry(path: str, dxl_id: Any, body: Any) -> tuple[Entry | None, list[str]]:
    """The servo of one ``servos:`` entry and every problem of it ([] when none)."""
    where = f"{cut_path(path)}: ID {cut(dxl_id)}"
    if not isinstance(dxl_id, int) or isinstance(dxl_id, bool) or not 0 <= dxl_id <= 252 or not isinstance(body, dict):
        return None, [f"{where}: not a servo ID 0..252 with its items"]
    try:
        model = any_model(int(str(body.get("model_number"))))
    except (KeyError, TypeError, ValueError):
        return None, [f"{where}: model_number {cut(body.get('model_number'))} is not one the tool knows"]
    values = body.get("eeprom")
    if not isinstance(values, dict):
        return None, [f"{where}: no 'eeprom:' map of items"]
    good, found = _values(model, values, where)
    found += [f"{where}: {p.text}" for p in problems(model, good, good, dxl_id) if not p.forcible]
    return Entry(dxl_id, model, good), found


def load(path: str) -> dict[int, Entry]:
    """Every servo of the backup at ``path``, each item checked; BadArguments (one line: the first
    problem and how many there are) before the bus is used when anything is wrong."""
    data = _yaml(path)
    servos = data.get("servos") if isinstance(data, dict) else None
    if not isinstance(servos, dict) or not servos:
        raise BadArguments(f"{cut_path(path)} is not a backup of this tool (no 'servos:' map of IDs)")
    entries: dict[int, Entry] = {}
    found: list[str] = []
    for dxl_id, body in servos.items():
        entry, wrong = _entry(path, dxl_id, body)
        found += wrong
        if entry is not None and not wrong:
            entries[entry.dxl_id] = entry
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise BadArguments(f"{found[0]}: refused, nothing written{more}")
    return entries
