"""``--trace``: every packet on the wire, as Dynamixel Wizard's packet view shows it, in a terminal.

Each instruction the tool sends and each status a servo sends back is one line on stderr (stdout
stays the verb's output or JSON): the seconds since the bus was opened, the direction (``>`` sent,
``<`` received), the bytes in hex and what they mean (``read ID 1 @132 x4 (present_position)``,
``status ID 1 ok: 2048 (present_position)``). The tool's own port is watched where the bytes go
out and come in, so nothing the bus layer does is left out (retries and broadcast pings included).
Item names come from the model each servo gave in its ping reply (ROBOTIS e-Manual, Protocol 2.0:
instruction and status packet layouts).
"""
from __future__ import annotations

import time
from typing import Any, Callable, TextIO

from ..bus import DynamixelBus
from ..control_table import Model, model_by_number
from ..protocol import HEADER, INSTRUCTION_NAMES, FrameReader
from ..protocol import host as p
from ..protocol import protocol1 as p1
from .per_protocol import tool_protocol
from .protocol1 import error_text1, statuses1

__all__ = ["install", "Tracer"]

#: bytes shown in hex per packet (longer ones are cut, with their length said)
_HEX_MAX = 48


def _hex(data: bytes) -> str:
    shown = " ".join(f"{b:02X}" for b in data[:_HEX_MAX])
    return shown + (f" ... ({len(data)} bytes)" if len(data) > _HEX_MAX else "")


def _u16(data: bytes, at: int) -> int:
    return data[at] | data[at + 1] << 8


class Tracer:
    """Decodes what goes out and comes in on one port and prints a line per packet."""

    def __init__(self, stream: TextIO, clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.clock = clock
        self.start = clock()
        self.reader = FrameReader(min_length=3)
        #: models learnt from ping replies: item names in the lines
        self.models: dict[int, Model] = {}
        #: (instruction, address, size) of the last request per ID, to read its reply
        self.asked: dict[int, tuple[int, int, int]] = {}
        self.answered = True
        self.protocol1 = False
        #: Protocol 1.0 reply bytes not yet shown (no whole status among them yet)
        self.pending1 = b""
        #: (address, size) of the last Protocol 1.0 read
        self.read1: tuple[int, int] | None = None
        #: models of the servos that answered Protocol 1.0 (an X set to Protocol Type 1 has its own table)
        self.models1: dict[int, Model] = {}
        #: those of each protocol
        self.models_of: dict[int, dict[int, Model]] = {2: self.models, 1: self.models1}

    def line(self, arrow: str, data: bytes, meaning: str) -> None:
        print(f"{self.clock() - self.start:9.4f} {arrow} {_hex(data):<50} {meaning}", file=self.stream, flush=True)

    def note(self, text: str) -> None:
        print(f"{self.clock() - self.start:9.4f}   {text}", file=self.stream, flush=True)

    def _item(self, dxl_id: int, address: int, size: int, protocol: int = 2) -> str:
        model = self.models_of[protocol].get(dxl_id)
        if model is None:
            return ""
        names = [i.name for i in model.items.values() if i.address == address and (i.size == size or not size)]
        if not names:
            last = [i.name for i in model.items.values() if address <= i.address < address + size]
            return f" ({last[0]}..{last[-1]})" if len(last) > 1 else (f" ({last[0]})" if last else "")
        return f" ({names[0]})"

    # ------------------------------------------------------------- sent
    def sent(self, packet: bytes) -> None:
        if self.pending1:
            self.line("<", self.pending1, "Protocol 1.0: no valid status in these bytes")
            self.pending1 = b""
        self.reader = FrameReader(min_length=3)
        self.answered = False
        if not packet.startswith(HEADER):
            self.protocol1 = True
            what = p1.INSTRUCTION_NAMES.get(packet[4] if len(packet) > 4 else 0, "instruction")
            where = f" @{packet[5]} x{packet[6]}" if what == "read" and len(packet) > 7 else ""
            if what == "write" and len(packet) > 7:  # header 2, ID, length, instruction, address, data, checksum
                where = f" @{packet[5]} = {int.from_bytes(packet[6:-1], 'little')}"
            self.read1 = (packet[5], packet[6]) if what == "read" and where else None
            self.line(">", packet, f"Protocol 1.0 {what} ID {packet[2] if len(packet) > 2 else '?'}{where}")
            return
        self.protocol1 = False
        for dxl_id, body, _size in FrameReader(min_length=3).frames(packet):
            self.line(">", packet, self._instruction(dxl_id, body[0], body[1:]))

    def _instruction(self, dxl_id: int, inst: int, params: bytes) -> str:
        name = INSTRUCTION_NAMES.get(inst, f"instruction 0x{inst:02X}")
        who = "all (broadcast)" if dxl_id == p.BROADCAST_ID else f"ID {dxl_id}"
        if inst == p.READ and len(params) >= 4:
            address, size = _u16(params, 0), _u16(params, 2)
            self.asked[dxl_id] = (inst, address, size)
            return f"read {who} @{address} x{size}{self._item(dxl_id, address, size)}"
        if inst == p.WRITE and len(params) >= 2:
            return self._write(who, dxl_id, _u16(params, 0), params[2:])
        if inst in (p.SYNC_READ, p.FAST_SYNC_READ, p.SYNC_WRITE) and len(params) >= 4:
            return self._sync(inst, name, params)
        self.asked[dxl_id] = (inst, 0, 0)
        if inst == p.FACTORY_RESET and params:
            return f"{name} {who} option 0x{params[0]:02X}"
        return f"{name} {who}" + (f" params {_hex(params)}" if params and inst != p.PING else "")

    def _write(self, who: str, dxl_id: int, address: int, data: bytes) -> str:
        self.asked[dxl_id] = (p.WRITE, address, len(data))
        shown = f" = {int.from_bytes(data, 'little')}" if len(data) <= 4 else f" {len(data)} bytes"
        return f"write {who} @{address}{shown}{self._item(dxl_id, address, len(data))}"

    def _sync(self, inst: int, name: str, params: bytes) -> str:
        address, size = _u16(params, 0), _u16(params, 2)
        if inst != p.SYNC_WRITE:
            ids = list(params[4:])
            for dxl_id in ids:
                self.asked[dxl_id] = (p.READ, address, size)
            item = self._item(ids[0], address, size) if ids else ""
            return f"{name} @{address} x{size}{item} IDs {', '.join(map(str, ids))}"
        parts, at = [], 4
        while at + 1 + size <= len(params):
            dxl_id, data = params[at], params[at + 1:at + 1 + size]
            parts.append(f"{dxl_id}={int.from_bytes(data, 'little', signed=True) if size <= 4 else _hex(data)}")
            at += 1 + size
        first = int(parts[0].split("=")[0]) if parts else -1
        return f"{name} @{address} x{size}{self._item(first, address, size)} {', '.join(parts)}"

    # ------------------------------------------------------------- received
    def received(self, data: bytes) -> None:
        if not data:
            if not self.answered:
                self.note("(no reply before the deadline)")
                self.answered = True
            return
        self.answered = True
        if self.protocol1:  # bytes gathered until they hold a status (a reply may come in pieces)
            self.pending1 += data
            found = statuses1(self.pending1)
            for dxl_id, error, params in found:
                self.line("<", self.pending1,
                          f"Protocol 1.0 status ID {dxl_id} {error_text1(error)}{self._value1(dxl_id, params)}")
            if found:
                self.pending1 = b""
            return
        for dxl_id, body, _size in self.reader.frames(data):
            if body[0] == p.STATUS and len(body) >= 2:
                frame = p.build_status(dxl_id, body[1], body[2:])
                self.line("<", frame, self._status(dxl_id, body[1], body[2:]))

    def _value1(self, dxl_id: int, params: bytes) -> str:
        """A Protocol 1.0 read's parameters: the model number (address 0 in every table a servo
        answering Protocol 1.0 has), else the value and the item, once the model is known."""
        if self.read1 == (0, 2) and len(params) == 2:
            number = _u16(params, 0)
            try:
                self.models1[dxl_id] = model = tool_protocol(1).model_for(number)
            except KeyError:
                return f": model {number} (not in the control table)"
            return f": model {number} ({model.name})"
        if self.read1 is None or not 0 < len(params) <= 4:
            return ""
        return f": {int.from_bytes(params, 'little')}{self._item(dxl_id, *self.read1, protocol=1)}"

    def _status(self, dxl_id: int, error: int, params: bytes) -> str:
        text = f"status ID {dxl_id} {p.error_text(error)}"
        inst, address, size = self.asked.get(dxl_id, (0, 0, 0))
        if len(params) == 3 and inst in (p.PING, 0):
            number = _u16(params, 0)
            try:
                model = model_by_number(number)
                self.models[dxl_id] = model
                named = model.name
            except KeyError:
                named = "not in the control table"
            return f"{text}: model {number} ({named}), firmware {params[2]}"
        if inst == p.READ and params and len(params) <= 4:
            return f"{text}: {int.from_bytes(params, 'little')}{self._item(dxl_id, address, size)}"
        return text + (f": {len(params)} bytes" if params else "")


def install(bus: DynamixelBus, stream: TextIO) -> Tracer:
    """Watch ``bus``'s port: every packet it writes and every byte it reads is traced to ``stream``."""
    tracer = Tracer(stream)
    port: Any = bus.line
    write, read_until, set_baudrate = port.write, port.read_until, port.set_baudrate

    def traced_write(packet: bytes) -> None:
        tracer.sent(bytes(packet))
        write(packet)

    def traced_read(*args: Any, **kwargs: Any) -> bytes:
        data = read_until(*args, **kwargs)
        tracer.received(bytes(data))
        return bytes(data)

    def traced_rate(baudrate: int) -> None:
        was = port.baudrate
        set_baudrate(baudrate)
        if baudrate != was:
            tracer.note(f"-- the bus at {baudrate} bps")

    port.write, port.read_until, port.set_baudrate = traced_write, traced_read, traced_rate
    tracer.note(f"-- {bus.device} at {bus.baudrate} bps")
    return tracer
