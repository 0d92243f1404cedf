"""Which handler node holds a serial device: a small record the node writes beside the port lock.

The lock (``lock_holder.py``) tells the pid that holds a device; the record tells which node that
is, so the set-up tool can go through the node's services with no flag. While a handler has the
device open it keeps ``dynamixel_handler_owner_<the device's path>.json`` (by the path it was given and by its real path) in
``$XDG_RUNTIME_DIR`` (else the system's temporary folder) with its pid, the pid's start time, its
full node name (namespace included) and its ROS domain; it removes it when it closes the device.
A record whose pid is gone, or is another process now (another start time), is stale and ignored.
ROS-free.
"""
from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from urllib.parse import quote

__all__ = ["Owner", "find_owner", "record_dirs", "remove_record", "write_record"]

_PREFIX = "dynamixel_handler_owner_"


@dataclass(frozen=True)
class Owner:
    pid: int
    #: the node's full name, namespace included (``/robot/dynamixel_handler``)
    node: str
    #: the node's namespace (``/robot``; ``/`` without one)
    namespace: str
    domain_id: int


def record_dirs() -> list[str]:
    """Where records are looked for, the first one written to: ``$XDG_RUNTIME_DIR``, the temp folder."""
    dirs = [d for d in (os.environ.get("XDG_RUNTIME_DIR"), tempfile.gettempdir()) if d]
    return list(dict.fromkeys(dirs))


def _names(device: str) -> list[str]:
    """The record's names for ``device``: by its path as given (a link, such as a by-id one, that
    outlives a reconnect to another tty) and by the tty it points to now."""
    keys = dict.fromkeys((os.path.abspath(device), os.path.realpath(device)))
    return [_PREFIX + quote(key, safe="") + ".json" for key in keys]


def _started(pid: int) -> str | None:
    """The start time of process ``pid`` (clock ticks since boot, ``/proc/PID/stat``); None when gone."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as handle:
            stat = handle.read()
    except OSError:
        return None
    fields = stat.rsplit(")", 1)[-1].split()  # the command name may hold spaces and brackets
    return fields[19] if len(fields) > 19 else None


def write_record(device: str, node: str, namespace: str, domain_id: int) -> list[str]:
    """Write this process's record for ``device``; the files written (none when no folder takes them)."""
    doc = {"pid": os.getpid(), "started": _started(os.getpid()), "node": node, "namespace": namespace,
           "domain_id": int(domain_id), "device": os.path.realpath(device)}
    for folder in record_dirs():
        try:
            written = []
            for name in _names(device):
                with tempfile.NamedTemporaryFile("w", dir=folder, prefix=".dxl_owner_", delete=False) as handle:
                    json.dump(doc, handle)
                os.replace(handle.name, os.path.join(folder, name))
                written.append(os.path.join(folder, name))
            return written
        except OSError:
            continue
    return []


def remove_record(paths: list[str]) -> None:
    """Remove the record files this process wrote (not one that is gone or another's now)."""
    for path in paths:
        try:
            with open(path, encoding="utf-8") as handle:
                mine = json.load(handle).get("pid") == os.getpid()
            if mine:
                os.unlink(path)
        except (OSError, ValueError, AttributeError):
            pass


def find_owner(device: str) -> Owner | None:
    """The live node that recorded ``device`` as its own; None when none did or its record is stale."""
    for folder, name in ((f, n) for n in _names(device) for f in record_dirs()):
        try:
            with open(os.path.join(folder, name), encoding="utf-8") as handle:
                doc = json.load(handle)
            owner = Owner(int(doc["pid"]), str(doc["node"]), str(doc["namespace"]), int(doc["domain_id"]))
            started = doc.get("started")
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            continue
        if started is not None and _started(owner.pid) == started:
            return owner
    return None
