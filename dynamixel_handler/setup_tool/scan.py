"""Finding servos: every baud rate and ID, Protocol 2.0 (one broadcast ping per rate, then a ping
per ID only where the reply train was garbled) and Protocol 1.0 (a ping per ID), with the details a
person needs (model, firmware, mode, torque, hardware error) and two servos at one ID told apart
from one: their replies collide (CRC errors or bytes that belong to no reply, at that ID only)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Callable, Sequence

from ..bus import BusError, DynamixelBus
from ..bus.census import census, noise, rounds
from ..bus.ops import Read
from ..control_table import FAMILIES, PROTOCOL1_FAMILIES, model_by_number, protocol1_model_by_number
from ..units import decode_hardware_error
from .errors import StepFailed
from .per_protocol import tool_protocol
from .protocol1 import model_name1, ping1, switch_to_2
from .servo import Servo

__all__ = ["Found", "ScanResult", "scan_bus", "scan_steps"]

#: bytes of one ping's status reply (Protocol 2.0: header 4, ID, length 2, instruction, error, 3 params, CRC 2)
_PING_REPLY_BYTES = 14


@dataclass
class Found:
    """One servo (or one ID where servos collide) seen by the scan."""

    dxl_id: int
    baudrate: int
    protocol: int
    model_number: int | None = None
    model: str = "?"
    firmware: int | None = None
    mode: str = ""
    torque: bool | None = None
    hardware_error: list[str] = field(default_factory=list)
    collision: bool = False
    note: str = ""

    def row(self) -> list[object]:
        return [self.dxl_id, self.model, "" if self.model_number is None else self.model_number,
                "" if self.firmware is None else self.firmware, self.baudrate, f"{self.protocol}.0", self.mode,
                {True: "on", False: "off", None: ""}[self.torque], ",".join(self.hardware_error) or "-",
                self.note]


COLUMNS = ["ID", "model", "number", "firmware", "baud", "protocol", "mode", "torque", "hardware error", "note"]


@dataclass
class ScanResult:
    found: list[Found] = field(default_factory=list)
    #: rates the adapter refused, with why
    skipped: dict[int, str] = field(default_factory=dict)
    #: the rate a signal stopped the scan at (what was found until then is kept), None: complete
    interrupted_at: int | None = None

    def as_dict(self) -> dict[str, object]:
        return {"servos": [_doc(f) for f in self.found], "skipped_rates": {str(k): v for k, v in self.skipped.items()}}


def _doc(found: Found) -> dict[str, object]:
    """A found servo in the JSON shape of every verb (``id``, ``model``, ``model_number``, ``baudrate``, ...)."""
    doc = asdict(found)
    doc["id"] = doc.pop("dxl_id")
    return {"id": doc.pop("id"), **doc}


#: each ID's time slot in a broadcast ping's reply train [ms] (as the bus waits for it)
_SLOT_MS = 3.0


def _broadcast_ms(bps: int, ids: Sequence[int], latency_ms: float) -> float:
    return 2 * latency_ms + (max(ids) + 1) * (_PING_REPLY_BYTES * 10_000.0 / bps + _SLOT_MS)


def _ping1_ms(bps: int, latency_ms: float) -> float:
    return 2 * latency_ms + 12 * 10_000.0 / bps


def scan_steps(rates: Sequence[int], ids: Sequence[int], protocols: Sequence[int], latency_ms: float) -> float:
    """Progress units of a scan: the time [ms] its steps should take, so the time left is right."""
    total = 0.0
    for bps in rates:
        if 2 in protocols:
            total += _broadcast_ms(bps, ids, latency_ms)
        if 1 in protocols:
            total += len(ids) * _ping1_ms(bps, latency_ms)
    return total


def _details(bus: DynamixelBus, dxl_id: int, number: int) -> Found:
    found = Found(dxl_id, bus.baudrate, 2, number, firmware=bus.firmware_versions.get(dxl_id))
    try:
        servo = Servo(bus, dxl_id, model_by_number(number))
    except KeyError:
        found.model = f"unknown ({number})"
        found.note = "model not in the control table: the handler cannot drive it"
        return found
    found.model = servo.model.name
    model = servo.model
    for name, setter in (("operating_mode", lambda v: setattr(found, "mode", model.mode_name(v) or str(v))),
                         ("torque_enable", lambda v: setattr(found, "torque", v == 1)),
                         ("hardware_error_status", lambda v: setattr(found, "hardware_error", _errors(v)))):
        if servo.model.has(name):
            _read_into(servo, name, setter)
    return found


def _read_into(servo: Servo, name: str, setter: Callable[[int], None]) -> None:
    item = servo.model.item(name)
    got = servo.execute(Read(servo.dxl_id, item.address, item.size, protocol=servo.protocol))
    if got.value is not None:
        setter(int.from_bytes(got.value[:item.size], "little"))


def _errors(bits: int) -> list[str]:
    return [name for name, on in decode_hardware_error(bits).items() if bool(on[0])]


#: what a scan says of an ID two servos share (Protocol 2.0 or 1.0)
_SHARED_NOTE = ("two or more servos answer at this ID (garbled or doubled replies; how many, the wire cannot tell): "
                "connect them one at a time with assign-ids, each gets its own ID")


def _scan_protocol2(bus: DynamixelBus, ids: Sequence[int], result: ScanResult) -> None:
    seen = census(bus, ids, broadcast=len(ids) >= 5, thorough=True, protocol=2)
    for dxl_id in sorted({*seen.found, *seen.shared}):
        number = seen.found.get(dxl_id, seen.shared.get(dxl_id))
        found = _details(bus, dxl_id, number) if number is not None else Found(dxl_id, bus.baudrate, 2)
        if dxl_id in seen.shared:
            found.collision = True
            found.note = _SHARED_NOTE
        result.found.append(found)


#: up to this many IDs, the Protocol 1.0 scan pings an ID that did not answer again (``--retries``)
RETRIED_IDS = 16


def _scan_protocol1(bus: DynamixelBus, ids: Sequence[int], result: ScanResult, tick: Callable[[], None]) -> None:
    # a few IDs (assign-ids near the factory ID, --ids): a missed reply is pinged again as --retries
    # says (a loaded host delays it); all 253: once each, a rate costs seconds already
    retries = None if len(ids) <= RETRIED_IDS else 0
    for dxl_id in ids:  # a Protocol 2.0 servo at the same ID ignores these packets
        tick()
        before = noise(bus)
        number = ping1(bus, dxl_id, retries)  # 0: it answers pings only
        if number is None and noise(bus) == before:
            continue
        probed, shared = rounds(bus, dxl_id, protocol=1)  # two servos at one ID garble or double every reply
        if shared:
            result.found.append(Found(dxl_id, bus.baudrate, 1, probed, model_name1(probed) if probed else "?",
                                      collision=True, note=_SHARED_NOTE))
            continue
        number = number if number is not None else probed
        if number is None:
            continue
        name, note = _protocol1_note(number, dxl_id)
        found = Found(dxl_id, bus.baudrate, 1, number, name, note=note)
        if number:
            _details1(bus, found)
        result.found.append(found)


def _details1(bus: DynamixelBus, found: Found) -> None:
    """Mode (a Protocol 1.0 model's from its Angle Limits), torque and the status's error bits."""
    try:
        servo = Servo(bus, found.dxl_id, tool_protocol(1).model_for(found.model_number or 0), 1)
    except KeyError:
        return
    try:
        if servo.model.has("firmware_version"):  # at 2 on a 1.0 model, at 6 on an X set to Protocol Type 1
            found.firmware = servo.read("firmware_version")
        found.mode = servo.mode() or ""
        found.torque = servo.torque_on() if servo.model.has("torque_enable") else None
        found.hardware_error = servo.status_errors()
    except StepFailed:  # Status Return Level 0: it answers pings only
        found.note += "; it answers pings only (Status Return Level 0)"


def _protocol1_note(number: int, dxl_id: int) -> tuple[str, str]:
    """The name of a servo that answered Protocol 1.0 and what its owner can do about it."""
    twin = switch_to_2(number)
    if twin is not None:
        return model_name1(number), (
            f"Protocol 1.0 firmware: {_ALL_VERBS}; {_driven(number)}; to switch it to Protocol 2.0 install its 2.0 "
            f"firmware (DYNAMIXEL Wizard 2.0, Firmware Recovery, {twin}(2.0))")
    try:
        model = model_by_number(number)
    except KeyError:
        if number == 0:
            return "?", "answers a Protocol 1.0 ping only (Status Return Level 0): set it to 1 or 2 with another tool"
        return model_name1(number), (f"Protocol 1.0 only (no Protocol 2.0 firmware exists for it): {_driven(number)}; "
                                     f"{_ALL_VERBS}")
    item = model.items.get("protocol_type")
    where = f" (address {item.address})" if item is not None else ""
    return model.name, (f"a Protocol 2.0 model set to Protocol Type 1: `set {dxl_id} protocol_type 2`{where} brings it "
                        "back to Protocol 2.0, where the handler reaches it; every verb of this tool reaches it now")


def _driven(number: int) -> str:
    """Whether the handler drives a Protocol 1.0 model: its family has an ``init/used_servo_series``
    key (every family of ``control_table``: ``config.USED_FAMILIES``, off by default) or not."""
    try:
        family = protocol1_model_by_number(number).family
    except KeyError:
        return "the handler does not drive it"
    if family in FAMILIES + PROTOCOL1_FAMILIES:
        return f"the handler drives it with init/used_servo_series.{family.title} true (off by default)"
    return "the handler does not drive it"


#: what the tool can do with a servo that answers Protocol 1.0
_ALL_VERBS = "every verb of this tool reads and writes it (info, get, set, set-mode, backup ...)"


def scan_bus(bus: DynamixelBus, rates: Sequence[int], ids: Sequence[int], protocols: Sequence[int],
             tick: Callable[[float, str | None], None]) -> ScanResult:
    """Every servo at ``rates`` x ``ids`` in ``protocols``; the bus is left at the first rate.
    ``tick(ms, what)``: progress in the units of ``scan_steps``. A signal (Ctrl-C) stops it with
    what was found until then (``interrupted_at``: the rate it was at)."""
    result = ScanResult()
    try:
        _scan_rates(bus, rates, ids, protocols, tick, result)
    except KeyboardInterrupt:
        result.interrupted_at = bus.baudrate
    result.found.sort(key=lambda f: (f.dxl_id, f.baudrate, f.protocol))
    return result


def _scan_rates(bus: DynamixelBus, rates: Sequence[int], ids: Sequence[int], protocols: Sequence[int],
                tick: Callable[[float, str | None], None], result: ScanResult) -> None:
    latency = bus.latency_timer_ms
    for bps in rates:
        try:
            bus.set_baudrate(bps)
        except BusError as exc:
            result.skipped[bps] = str(exc)
            tick(scan_steps([bps], ids, protocols, latency), None)
            continue
        if 2 in protocols:
            tick(0, f"{bps} bps, Protocol 2.0")
            _scan_protocol2(bus, ids, result)
            tick(_broadcast_ms(bps, ids, latency), None)
        if 1 in protocols:
            tick(0, f"{bps} bps, Protocol 1.0")
            step = _ping1_ms(bps, latency)
            _scan_protocol1(bus, ids, result, lambda: tick(step, None))
    if rates and rates[0] not in result.skipped:
        bus.set_baudrate(rates[0])
