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
from typing import Iterable, Mapping, Sequence

from .bus import BusStats, DynamixelBus, GroupRead, PreparedWrite, Result
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

    def _unusable(self, what: str) -> Result[None]:
        """Why a call for a real servo fails at once: the wire is closed or gone."""
        return Result(None, f"{what}: port closed or device lost")

    # ------------------------------------------------------------ single servo
    def ping_result(self, dxl_id: int, retries: int | None = None) -> Result[int | None]:
        if dxl_id in self.dummies:
            return Result(self.dummies[dxl_id].model.number)
        return self._bus.ping_result(dxl_id, retries) if self._real_ok() else self._unusable(f"ping ID {dxl_id}")

    def ping(self, dxl_id: int, retries: int | None = None) -> int | None:
        return self.ping_result(dxl_id, retries).value

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        real, dummy = self._split(ids)
        found = self._bus.scan(real, broadcast) if (real and self._real_ok()) else {}
        found.update({i: self.dummies[i].model.number for i in dummy})
        return dict(sorted(found.items()))

    def read_result(self, dxl_id: int, address: int, size: int) -> Result[bytes | None]:
        if dxl_id in self.dummies:
            error, data = self._dummy(dxl_id, now := time.monotonic()).host_read(address, size, now)
            if error & 0x7F:
                return Result(None, f"read ID {dxl_id} @{address}x{size}: {p.error_text(error)}")
            return Result(data)
        if not self._real_ok():
            return self._unusable(f"read ID {dxl_id} @{address}x{size}")
        return self._bus.read_result(dxl_id, address, size)

    def read(self, dxl_id: int, address: int, size: int) -> bytes | None:
        return self.read_result(dxl_id, address, size).value

    def write_result(self, dxl_id: int, address: int, data: bytes) -> Result[bool]:
        if dxl_id in self.dummies:
            error = self._dummy(dxl_id, now := time.monotonic()).host_write(address, bytes(data), now)
            return Result(False, f"write ID {dxl_id}: {p.error_text(error)}") if error & 0x7F else _DONE
        if not self._real_ok():
            return _failed(self._unusable(f"write ID {dxl_id}"))
        return self._bus.write_result(dxl_id, address, data)

    def write(self, dxl_id: int, address: int, data: bytes) -> bool:
        return self.write_result(dxl_id, address, data).value

    def reboot_result(self, dxl_id: int) -> Result[bool]:
        if dxl_id in self.dummies:
            self.dummies[dxl_id].reboot(time.monotonic())
            return _DONE
        return self._bus.reboot_result(dxl_id) if self._real_ok() else _failed(self._unusable(f"reboot ID {dxl_id}"))

    def reboot(self, dxl_id: int) -> bool:
        return self.reboot_result(dxl_id).value

    def clear_multi_turn_result(self, dxl_id: int) -> Result[bool]:
        if dxl_id in self.dummies:
            error = self.dummies[dxl_id].clear_multi_turn(CLEAR_KEY, time.monotonic())
            return Result(False, f"clear multi-turn ID {dxl_id}: {p.error_text(error)}") if error & 0x7F else _DONE
        if not self._real_ok():
            return _failed(self._unusable(f"clear multi-turn ID {dxl_id}"))
        return self._bus.clear_multi_turn_result(dxl_id)

    def clear_multi_turn(self, dxl_id: int) -> bool:
        return self.clear_multi_turn_result(dxl_id).value

    def clear_error_result(self, dxl_id: int, params: bytes) -> Result[bool]:
        if dxl_id in self.dummies:
            error = self.dummies[dxl_id].clear(bytes(params), time.monotonic())
            return Result(False, f"error clear ID {dxl_id}: {p.error_text(error)}") if error & 0x7F else _DONE
        if not self._real_ok():
            return _failed(self._unusable(f"error clear ID {dxl_id}"))
        return self._bus.clear_error_result(dxl_id, params)

    # ------------------------------------------------------------ groups
    def sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> dict[int, bytes]:
        real, dummy = self._split(ids)
        out = self._bus.sync_read(address, length, real, fast) if (real and self._real_ok()) else {}
        now = time.monotonic()
        for i in dummy:
            error, data = self._dummy(i, now).host_read(address, length, now)
            if not error & 0x7F:
                out[i] = data
        return out

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False) -> GroupRead:
        """As ``DynamixelBus.start_sync_read``; a read that includes dummies is done at once."""
        real, dummy = self._split(ids)
        if not dummy and self._real_ok():
            return self._bus.start_sync_read(address, length, real, fast)
        return GroupRead.finished(self.sync_read(address, length, ids, fast))

    def sync_write_result(self, address: int, length: int, data: Mapping[int, bytes]) -> Result[bool]:
        return self.send_prepared_result(self.prepare_sync_write(address, length, data))

    def sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> bool:
        return self.send_prepared_result(self.prepare_sync_write(address, length, data)).value

    def prepare_sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> PreparedWrite:
        """As ``DynamixelBus.prepare_sync_write``; the dummies' part is written when it is sent."""
        real = {i: d for i, d in data.items() if i not in self.dummies}
        prepared = self._bus.prepare_sync_write(address, length, real)
        dummy = {i: bytes(d) for i, d in data.items() if i in self.dummies}
        return dataclasses.replace(prepared, dummies=dummy) if dummy else prepared

    def send_prepared_result(self, prepared: PreparedWrite) -> Result[bool]:
        now = time.monotonic()
        for i, chunk in prepared.dummies.items():
            if i in self.dummies:
                self._dummy(i, now).host_write(prepared.address, chunk, now)
        if not prepared.packet:
            return _DONE
        if not self._real_ok():
            return _failed(self._unusable(f"sync write @{prepared.address}x{prepared.length}"))
        return self._bus.send_prepared_result(prepared)

    def send_prepared(self, prepared: PreparedWrite) -> bool:
        return self.send_prepared_result(prepared).value


_DONE: Result[bool] = Result(True)


def _failed(why: Result[None]) -> Result[bool]:
    return Result(False, why.failure)
