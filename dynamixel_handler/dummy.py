"""Dummy servos (``init/dummy_servo_list``): IDs handled with no hardware behind them.

Each dummy is a servo model of the virtual bus (same control table, same simple physics: it
follows its goals), served in-process. ``BusWithDummies`` stands in for the real bus: requests for
dummy IDs go to the models, everything else to the wire, so dummies and real servos mix freely
in one sync read or write. A dummy wins over a real servo of the same ID (the real one is never
addressed). ROS-free.
"""
from __future__ import annotations

import dataclasses
import time
from typing import Any, Iterable, Mapping, Sequence

from .bus import BusStats, DynamixelBus, Failure, GroupRead, PreparedWrite, Result
from .bus.ops import ClearError, ClearMultiTurn, Instruction, Ping, Read, Reboot, SyncRead, Write
from .control_table import family_named, model_by_number
from .protocol import host as p
from .sim.servo import CLEAR_KEY, VirtualServo


def make_dummies(ids: Iterable[int], series: str | Sequence[str]) -> dict[int, VirtualServo]:
    """Dummies of one series, or of the series given per ID (``ServoFamily.dummy_model``: XM430-W350,
    PH54-200-S500-R, H54-200-S500-R)."""
    ids = list(ids)
    per_id = [series] * len(ids) if isinstance(series, str) else list(series)
    return {i: VirtualServo(model_by_number(family_named(s).dummy_model), i, time.monotonic) for i, s in zip(ids, per_id)}


class BusWithDummies:
    """The bus API of ``DynamixelBus`` over real servos plus in-process dummies."""

    def __init__(self, bus: DynamixelBus, dummies: Mapping[int, VirtualServo]) -> None:
        self._bus = bus
        self.dummies = dict(dummies)

    # ------------------------------------------------------------ the real bus's own parts
    @property
    def device(self) -> str:
        return self._bus.device

    @property
    def baudrate(self) -> int:
        return self._bus.baudrate

    @property
    def latency_timer_ms(self) -> float:
        return self._bus.latency_timer_ms

    @property
    def inflight_eta(self) -> float | None:
        return self._bus.inflight_eta

    @property
    def stats(self) -> BusStats:
        return self._bus.stats

    def open(self) -> None:
        self._bus.open()

    def close(self) -> None:
        self._bus.close()

    def reopen(self) -> None:
        self._bus.reopen()

    def set_baudrate(self, baudrate: int) -> None:
        self._bus.set_baudrate(baudrate)

    # ------------------------------------------------------------ helpers
    def _split(self, ids: Iterable[int]) -> tuple[list[int], list[int]]:
        real: list[int] = []
        dummy: list[int] = []
        for i in ids:
            (dummy if i in self.dummies else real).append(i)
        return real, dummy

    def _real_ok(self) -> bool:
        return self._bus.is_open

    def _dummy(self, dxl_id: int, now: float) -> VirtualServo:
        servo = self.dummies[dxl_id]
        servo.note_instruction(now)  # feeds its bus watchdog, as an instruction on the wire would
        return servo

    @property
    def is_open(self) -> bool:
        return self._bus.is_open

    def _unusable(self, what: str, value: object = None) -> Result[Any]:
        """Why a call for a real servo fails at once: the wire is closed or gone."""
        return Result(value, Failure.PORT_CLOSED, f"{what}: port closed or device lost")

    # ------------------------------------------------------------ instructions
    def execute(self, instruction: Instruction) -> Result[Any]:
        """As ``DynamixelBus.execute``: an instruction to a dummy is done in-process, a sync read or
        write that includes dummies is split between them and the wire."""
        if isinstance(instruction, PreparedWrite):
            return self._send_prepared(instruction)
        if isinstance(instruction, SyncRead):
            return self._sync_read(instruction)
        if isinstance(instruction, _TO_ONE) and instruction.dxl_id in self.dummies:
            return self._in_process(instruction)
        if not self._real_ok():
            return self._unusable(_what(instruction), None if isinstance(instruction, (Ping, Read)) else False)
        return self._bus.execute(instruction)

    def _in_process(self, op: ToOne) -> Result[Any]:
        """An instruction to a dummy servo, answered as the servo would."""
        now = time.monotonic()
        servo = self._dummy(op.dxl_id, now)
        if isinstance(op, Ping):
            return Result(servo.model.number)
        if isinstance(op, Read):
            error, data = servo.host_read(op.address, op.size, now)
            return _refused(None, op, error) if error & 0x7F else Result(data)
        if isinstance(op, Write):
            error = servo.host_write(op.address, op.data, now)
        elif isinstance(op, Reboot):
            servo.reboot(now)
            error = 0
        elif isinstance(op, ClearMultiTurn):
            error = servo.clear_multi_turn(CLEAR_KEY, now)
        elif isinstance(op, ClearError):
            error = servo.clear(op.params, now)
        else:
            return Result(False, Failure.REFUSED, f"{_what(op)}: not served by a dummy servo")
        return _refused(False, op, error) if error & 0x7F else _DONE

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        real, dummy = self._split(ids)
        found = self._bus.scan(real, broadcast) if (real and self._real_ok()) else {}
        found.update({i: self.dummies[i].model.number for i in dummy})
        return dict(sorted(found.items()))

    # ------------------------------------------------------------ groups
    def _sync_read(self, op: SyncRead) -> Result[dict[int, bytes]]:
        real, dummy = self._split(op.ids)
        out: dict[int, bytes] = {}
        failure, why = None, ""
        if real and self._real_ok():
            got = self._bus.execute(SyncRead(op.address, op.length, tuple(real), op.fast, op.protocol))
            out, failure, why = dict(got.value), got.failure, got.why
        now = time.monotonic()
        for i in dummy:
            error, data = self._dummy(i, now).host_read(op.address, op.length, now)
            if not error & 0x7F:
                out[i] = data
        return Result(out) if out or not op.ids else Result(out, failure or Failure.NOBODY_ANSWERED,
                                                            why or f"sync read @{op.address}x{op.length}: no servo answered")

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        protocol: int = 2) -> GroupRead:
        """As ``DynamixelBus.start_sync_read``; a read that includes dummies is done at once."""
        real, dummy = self._split(ids)
        if not dummy and self._real_ok():
            return self._bus.start_sync_read(address, length, real, fast, protocol)
        done = self._sync_read(SyncRead(address, length, tuple(ids), fast, protocol))
        read = GroupRead.finished(done.value)
        read.failure, read.why = done.failure, done.why
        return read

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes], protocol: int = 2) -> PreparedWrite:
        """As ``DynamixelBus.prepare_sync_write``; the dummies' part is written when it is sent."""
        real = {i: d for i, d in data.items() if i not in self.dummies}
        prepared = self._bus.prepare_sync_write(address, length, real, protocol)
        dummy = {i: bytes(d) for i, d in data.items() if i in self.dummies}
        return dataclasses.replace(prepared, dummies=dummy) if dummy else prepared

    def _send_prepared(self, prepared: PreparedWrite) -> Result[bool]:
        now = time.monotonic()
        for i, chunk in prepared.dummies.items():
            if i in self.dummies:
                self._dummy(i, now).host_write(prepared.address, chunk, now)
        if not prepared.packet:
            return _DONE
        if not self._real_ok():
            return self._unusable(f"sync write @{prepared.address}x{prepared.length}", False)
        return self._bus.execute(prepared)


_DONE: Result[bool] = Result(True)
#: the instructions to one servo (the dummies answer these)
_TO_ONE = (Ping, Read, Write, Reboot, ClearMultiTurn, ClearError)
ToOne = Ping | Read | Write | Reboot | ClearMultiTurn | ClearError


def _what(op: Instruction) -> str:
    """An instruction as a log line names it: "read ID 3 @132x4", "sync write @116x4"."""
    name = {Ping: "ping", Read: "read", Write: "write", Reboot: "reboot", ClearMultiTurn: "clear multi-turn",
            ClearError: "error clear"}.get(type(op), type(op).__name__)
    where = f" ID {op.dxl_id}" if hasattr(op, "dxl_id") else ""
    if isinstance(op, Read):
        where += f" @{op.address}x{op.size}"
    return name + where


def _refused(value: object, op: Instruction, error: int) -> Result[Any]:
    return Result(value, Failure.REFUSED, f"{_what(op)}: {p.error_text(error)}")
