"""``device_name: serial:<USB serial number>``: find the adapter by its identity, not its tty. ROS-free.

``/dev/ttyUSB0`` is whichever adapter the kernel enumerated first; a robot with two buses (or an
adapter plugged into another port) needs a name that stays. udev's ``/dev/serial/by-id/`` links
carry the adapter's USB serial number (``usb-FTDI_USB__-__Serial_Converter_FT4TFSJ1-if00-port0``:
serial number ``FT4TFSJ1``), and pyserial's port list reads it from sysfs. ``serial:FT4TFSJ1``
is looked up in the links first (the link is kept as the device path, so a reconnect finds the
adapter even when it comes back as another tty), then in pyserial's list. A plain path
(``/dev/ttyUSB0``, ``/dev/serial/by-id/...``) is used as given.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Callable, Iterable

from .errors import StartupError

PREFIX = "serial:"
BY_ID_DIR = "/dev/serial/by-id"
#: environment variable naming another folder of by-id links (tests, containers with their own udev)
BY_ID_ENV = "DYNAMIXEL_HANDLER_SERIAL_BY_ID_DIR"
_BY_ID = re.compile(r"^(?:usb|pci)-(?P<product>.*)_(?P<serial>[^_]+?)-if(?P<interface>[0-9a-fA-F]+)(?:-port\d+)?$")


@dataclass(frozen=True)
class Adapter:
    serial: str
    path: str       # what to open: the by-id link, or the tty pyserial names
    tty: str        # the tty it is now
    source: str     # "by-id" or "pyserial"


def serial_of_link(name: str) -> str | None:
    """The USB serial number in a /dev/serial/by-id link name, None when it carries none."""
    m = _BY_ID.match(name)
    return m.group("serial") if m else None


def adapters(by_id_dir: str | None = None, comports: Callable[[], Iterable[object]] | None = None) -> list[Adapter]:
    """Every adapter with a USB serial number: by-id links first, then pyserial's ports not linked."""
    found: list[Adapter] = []
    folder = by_id_dir if by_id_dir is not None else os.environ.get(BY_ID_ENV, BY_ID_DIR)
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        names = []
    for name in names:
        serial = serial_of_link(name)
        if serial is not None:
            path = os.path.join(folder, name)
            found.append(Adapter(serial, path, os.path.realpath(path), "by-id"))
    seen = {a.tty for a in found}
    for port in (comports if comports is not None else _pyserial_ports)():
        serial = getattr(port, "serial_number", None)
        device = getattr(port, "device", None)
        if serial and device and os.path.realpath(device) not in seen:
            found.append(Adapter(str(serial), device, os.path.realpath(device), "pyserial"))
    return found


def _pyserial_ports() -> Iterable[object]:
    try:
        from serial.tools.list_ports import comports
    except ImportError:  # pyserial without its tools: the links are all there is
        return []
    ports: Iterable[object] = comports()
    return ports


def resolve(device_name: str, by_id_dir: str | None = None,
            comports: Callable[[], Iterable[object]] | None = None) -> tuple[str, str | None]:
    """(the device to open, a line saying which adapter was chosen or None for a plain path).
    StartupError listing the adapters seen when no adapter has that serial number."""
    if not device_name.startswith(PREFIX):
        return device_name, None
    wanted = device_name[len(PREFIX):].strip()
    if not wanted:
        raise StartupError(f"device_name '{device_name}' gives no serial number: write serial:<USB serial number>, "
                           "e.g. serial:FT4TFSJ1 (ls /dev/serial/by-id shows them)")
    every = adapters(by_id_dir, comports)
    matches = _matching(every, wanted)
    if not matches:
        seen = ", ".join(f"{a.serial} ({a.tty})" for a in every) or "none with a USB serial number"
        raise StartupError(f"device_name '{device_name}': no adapter with USB serial number {wanted}; adapters seen: {seen}")
    chosen = matches[0]  # a multi-port adapter has one link per interface: the first (if00) is taken
    others = sorted({a.path for a in matches if a.tty != chosen.tty})
    line = f"device_name '{device_name}': adapter {chosen.path} (now {chosen.tty}, found in {chosen.source})"
    if others:
        line += f"; the same serial number also has {', '.join(others)}"
    return chosen.path, line


def _matching(every: list[Adapter], wanted: str) -> list[Adapter]:
    """The adapters whose serial number is ``wanted``; compared ignoring case when none match exactly."""
    return [a for a in every if a.serial == wanted] or [a for a in every if a.serial.lower() == wanted.lower()]
