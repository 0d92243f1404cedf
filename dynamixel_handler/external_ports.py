"""External ports of X540, P and Pro servos (``option/external_port.*``). ROS-free.

A write names (ID, port) pairs, optionally with a mode and/or data; from then on only the ports
named in a write are read: data every ``pub_ratio/data`` loops, mode every ``pub_ratio/mode``
loops. Mode ``unset`` stops reading a port. Work queued from callbacks runs in the loop thread.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Sequence, assert_never

from .core.handler import Handler
from .servo.groups import due
from .servo.table import ServoTable
from .settings import ExternalPortSettings

MODES = {"a_in": 0, "d_out": 1, "d_in_pu": 2, "d_in_pd": 3}
MODE_NAMES = {v: k for k, v in MODES.items()}


@dataclass(frozen=True)
class PortWrite:
    """external_port/write: modes and data of ports, checked and written in the loop thread."""

    ids: list[int]
    ports: list[int]
    modes: list[str] | None
    data: list[int] | None
    what: str = "external_port/write"
UNSET = "unset"


@dataclass
class PortReading:
    ids: list[int] = field(default_factory=list)
    ports: list[int] = field(default_factory=list)
    modes: list[str] = field(default_factory=list)
    data: list[int] = field(default_factory=list)


class ExternalPorts:
    def __init__(self, handler: Handler, settings: ExternalPortSettings) -> None:
        self.h = handler
        self.data_ratio, self.mode_ratio = settings.data_ratio, settings.mode_ratio
        self.verbose_callback, self.verbose_write = settings.verbose_callback, settings.verbose_write
        self.verbose_read, self.verbose_err = settings.verbose_read, settings.verbose_err
        self.watched: dict[tuple[int, int], None] = {}  # insertion-ordered set of (id, port)
        self._loop = 0

    # ------------------------------------------------------------ commands (any thread)
    def write(self, ids: Sequence[int], ports: Sequence[int], modes: Sequence[str], data: Sequence[int]) -> None:
        n = len(ids)
        if n == 0:
            return
        if len(ports) != n:
            self.h.log.warning(f"external_port/write: 'port' has {len(ports)} values for {n} IDs: ignored")
            return
        given_modes = self._same_length("mode", modes, n)
        given_data = self._same_length("data", data, n)
        if self.verbose_callback:
            self.h.log.info(f"external_port/write: ids={list(ids)} ports={list(ports)} modes={given_modes} data={given_data}")
        self.h.submit(PortWrite(list(ids), list(ports), given_modes, given_data))

    def _same_length(self, name: str, values: Sequence, n: int) -> list | None:
        if len(values) == 0:
            return None
        if len(values) != n:
            self.h.log.warning(f"external_port/write: '{name}' has {len(values)} values for {n} IDs: ignored")
            return None
        return list(values)

    # ------------------------------------------------------------ loop thread
    TAKES: ClassVar[tuple[type, ...]] = (PortWrite,)

    def handle(self, request: PortWrite) -> None:
        """A queued port write, in the loop thread (attached to the intake by who builds this)."""
        match request:
            case PortWrite():
                self._write(request)
            case _:
                assert_never(request)

    def _write(self, request: PortWrite) -> None:
        ids, ports, modes, data = request.ids, request.ports, request.modes, request.data
        table = self.h.table
        for k, (dxl_id, port) in enumerate(zip(ids, ports)):
            where = f"external_port/write: ID {dxl_id} port {port}"
            if not self._has_port(table, where, dxl_id, port):
                continue
            if modes is not None and not self._write_mode(where, dxl_id, port, modes[k]):
                continue
            if data is not None:
                self._write_data(where, dxl_id, port, data[k])
            self.watched[(dxl_id, port)] = None

    def _has_port(self, table: ServoTable, where: str, dxl_id: int, port: int) -> bool:
        """Whether ``dxl_id`` is handled and its model has ``port``; a warning when not."""
        if dxl_id not in table:
            self.h.log.warning(f"{where}: ID not handled: ignored")
            return False
        model = table.model(dxl_id)
        if port not in model.external_ports:
            have = f"ports {list(model.external_ports)}" if model.external_ports else "no external ports"
            self.h.log.warning(f"{where}: {model.name} has {have}: ignored")
            return False
        return True

    def _write_mode(self, where: str, dxl_id: int, port: int, given: object) -> bool:
        """Set the port's mode (``unset``: stop watching it); False when the rest of the write for
        this port is dropped: unset, an unknown mode, or a failed write."""
        mode = str(given).strip()
        if mode == UNSET:
            self.watched.pop((dxl_id, port), None)
            return False
        if mode not in MODES:
            self.h.log.warning(f"{where}: unknown mode '{mode}' (known: {', '.join([*MODES, UNSET])}): ignored")
            return False
        written = self.h.core.write_eeprom(dxl_id, f"external_port_mode_{port}", MODES[mode])
        if not written:
            self.h.log.warning(f"{where}: writing mode {mode} failed: {written.failure}")
            return False
        if self.verbose_write:
            self.h.log.info(f"{where}: mode -> {mode}")
        return True

    def _write_data(self, where: str, dxl_id: int, port: int, value: Any) -> None:
        """Write digital output data (0 or 1) to a port in mode d_out; a warning otherwise."""
        if isinstance(value, float) and not math.isfinite(value):
            self.h.log.warning(f"{where}: data {value} refused")
        elif self._mode(dxl_id, port) != "d_out":
            self.h.log.warning(f"{where}: data is written only in mode d_out: ignored")
        elif value not in (0, 1):
            self.h.log.warning(f"{where}: digital output data must be 0 or 1, got {value}: ignored")
        else:
            self.h.core.write_item(dxl_id, f"external_port_data_{port}", int(value))
            if self.verbose_write:
                self.h.log.info(f"{where}: data -> {value}")

    def _mode(self, dxl_id: int, port: int) -> str | None:
        value = self.h.table.value(f"external_port_mode_{port}", dxl_id)
        if value is None:
            value = self.h.read_item(dxl_id, f"external_port_mode_{port}")
        return _mode_name(value)

    def step(self) -> PortReading | None:
        """Read the watched ports when their ratios say so; None when nothing was read."""
        loop, self._loop = self._loop, self._loop + 1
        read_data, read_mode = due(self.data_ratio, loop), due(self.mode_ratio, loop)
        if not self.watched or not (read_data or read_mode):
            return None
        out = PortReading()
        for dxl_id, port in list(self.watched):
            if dxl_id not in self.h.table:
                self.watched.pop((dxl_id, port), None)
                continue
            reading = self._read_port(dxl_id, port, read_data, read_mode)
            if reading is None:
                continue
            out.ids.append(dxl_id)
            out.ports.append(port)
            out.modes.append(reading[0])
            out.data.append(reading[1])
        if self.verbose_read and out.ids:
            self.h.log.info(f"external_port/read: {list(zip(out.ids, out.ports, out.modes, out.data))}")
        return out if out.ids else None

    def _read_port(self, dxl_id: int, port: int, read_data: bool, read_mode: bool) -> tuple[str, int] | None:
        """(mode, data) of one port: what is due read from the servo, the rest as last known
        ("" / -1: not known); None when a due read got no answer."""
        if read_mode:
            mode = _mode_name(self.h.read_item(dxl_id, f"external_port_mode_{port}"))
        else:
            mode = self._mode(dxl_id, port)
        data = self.h.read_item(dxl_id, f"external_port_data_{port}") if read_data else None
        if (read_data and data is None) or (read_mode and mode is None):
            if self.verbose_err:
                self.h.log.warning(f"external_port/read: ID {dxl_id} port {port}: no answer")
            return None
        if data is None:
            data = self.h.table.value(f"external_port_data_{port}", dxl_id)
        return mode or "", int(data) if data is not None else -1


def _mode_name(value: int | None) -> str | None:
    """The mode name of a mode register value (None: not read, or not a known mode)."""
    return MODE_NAMES.get(value) if value is not None else None


__all__ = ["ExternalPorts", "PortReading", "MODES", "UNSET"]
