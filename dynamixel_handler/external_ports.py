"""External ports of X540, P and Pro servos (``option/external_port.*``). ROS-free.

A write names (ID, port) pairs, optionally with a mode and/or data; from then on only the ports
named in a write are read: data every ``pub_ratio/data`` loops, mode every ``pub_ratio/mode``
loops. Mode ``unset`` stops reading a port. Work queued from callbacks runs in the loop thread.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

from .groups import due
from .loop import Handler

MODES = {"a_in": 0, "d_out": 1, "d_in_pu": 2, "d_in_pd": 3}
MODE_NAMES = {v: k for k, v in MODES.items()}
UNSET = "unset"


@dataclass
class PortReading:
    ids: list[int] = field(default_factory=list)
    ports: list[int] = field(default_factory=list)
    modes: list[str] = field(default_factory=list)
    data: list[int] = field(default_factory=list)


class ExternalPorts:
    def __init__(self, handler: Handler) -> None:
        self.h = handler
        cfg = handler.config
        self.data_ratio = cfg["option/external_port.pub_ratio/data"]
        self.mode_ratio = cfg["option/external_port.pub_ratio/mode"]
        self.verbose_callback = cfg["option/external_port.verbose/callback"]
        self.verbose_write = cfg["option/external_port.verbose/write"]
        self.verbose_read = cfg["option/external_port.verbose/read.raw"]
        self.verbose_err = cfg["option/external_port.verbose/read.err"]
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
        modes = self._same_length("mode", modes, n)
        data = self._same_length("data", data, n)
        if self.verbose_callback:
            self.h.log.info(f"external_port/write: ids={list(ids)} ports={list(ports)} modes={modes} data={data}")
        self.h.queue("external_port/write", lambda: self._write(list(ids), list(ports), modes, data))

    def _same_length(self, name: str, values: Sequence, n: int) -> list | None:
        if len(values) == 0:
            return None
        if len(values) != n:
            self.h.log.warning(f"external_port/write: '{name}' has {len(values)} values for {n} IDs: ignored")
            return None
        return list(values)

    # ------------------------------------------------------------ loop thread
    def _write(self, ids: list[int], ports: list[int], modes: list | None, data: list | None) -> None:
        table = self.h.table
        for k, (dxl_id, port) in enumerate(zip(ids, ports)):
            where = f"external_port/write: ID {dxl_id} port {port}"
            if dxl_id not in table:
                self.h.log.warning(f"{where}: ID not handled: ignored")
                continue
            model = table.model(dxl_id)
            if port not in model.external_ports:
                have = f"ports {list(model.external_ports)}" if model.external_ports else "no external ports"
                self.h.log.warning(f"{where}: {model.name} has {have}: ignored")
                continue
            if modes is not None:
                mode = str(modes[k]).strip()
                if mode == UNSET:
                    self.watched.pop((dxl_id, port), None)
                    continue
                if mode not in MODES:
                    self.h.log.warning(f"{where}: unknown mode '{mode}' (known: {', '.join([*MODES, UNSET])}): ignored")
                    continue
                if not self.h.write_eeprom(dxl_id, f"external_port_mode_{port}", MODES[mode]):
                    self.h.log.warning(f"{where}: writing mode {mode} failed: {self.h.bus.last_failure}")
                    continue
                if self.verbose_write:
                    self.h.log.info(f"{where}: mode -> {mode}")
            if data is not None:
                value = data[k]
                if isinstance(value, float) and not math.isfinite(value):
                    self.h.log.warning(f"{where}: data {value} refused")
                elif self._mode(dxl_id, port) != "d_out":
                    self.h.log.warning(f"{where}: data is written only in mode d_out: ignored")
                elif value not in (0, 1):
                    self.h.log.warning(f"{where}: digital output data must be 0 or 1, got {value}: ignored")
                else:
                    self.h.write_item(dxl_id, f"external_port_data_{port}", int(value))
                    if self.verbose_write:
                        self.h.log.info(f"{where}: data -> {value}")
            self.watched[(dxl_id, port)] = None

    def _mode(self, dxl_id: int, port: int) -> str | None:
        value = self.h.table.value(f"external_port_mode_{port}", dxl_id)
        if value is None:
            value = self.h.read_item(dxl_id, f"external_port_mode_{port}")
        return MODE_NAMES.get(value) if value is not None else None

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
            mode = self._mode(dxl_id, port) if not read_mode else None
            if read_mode:
                value = self.h.read_item(dxl_id, f"external_port_mode_{port}")
                mode = MODE_NAMES.get(value) if value is not None else None
            data = self.h.read_item(dxl_id, f"external_port_data_{port}") if read_data else None
            if (read_data and data is None) or (read_mode and mode is None):
                if self.verbose_err:
                    self.h.log.warning(f"external_port/read: ID {dxl_id} port {port}: no answer")
                continue
            if data is None:
                data = self.h.table.value(f"external_port_data_{port}", dxl_id)
            out.ids.append(dxl_id)
            out.ports.append(port)
            out.modes.append(mode or "")
            out.data.append(int(data) if data is not None else -1)
        if self.verbose_read and out.ids:
            self.h.log.info(f"external_port/read: {list(zip(out.ids, out.ports, out.modes, out.data))}")
        return out if out.ids else None


__all__ = ["ExternalPorts", "PortReading", "MODES", "UNSET"]
