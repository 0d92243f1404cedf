"""Protocol 1.0 servos on the virtual bus: an AX-12A, AX-18A or MX-28 (1.0 firmware).

The handler drives Protocol 2.0 servos only; these sit on the bus so that a scan meets what an
owner's old servos really do: they answer Protocol 1.0 packets (``FF FF ID LEN INST PARAMS CHK``,
the checksum being the inverted low byte of the sum from ID on) and ignore Protocol 2.0 ones, as
the 2.0 servos ignore theirs. They are a small table of their own, never ``known_models()``.

Facts (ROBOTIS e-Manual, AX-12A / AX-18A / MX-28 pages, Protocol 1.0): the control table
addresses, sizes and initial values below; Baud Rate value v runs at 2,000,000 / (v + 1) bps
(1 = 1 Mbps, 34 = 57600 with a 0.794 % error, 207 = 9600), the MX adding 250 = 2.25 M,
251 = 2.5 M, 252 = 3 M; less than 3 % of error does not affect the UART, so a servo hears a host
within 3 % of its rate; Return Delay Time in 2 µs; Status Return Level 0 answers only PING,
1 also READ, 2 everything; a broadcast (ID 254) is never answered; the status error bits are
0 input voltage, 1 angle limit, 2 overheating, 3 range, 4 checksum, 5 overload, 6 instruction.
The firmware version is representative (the pages leave it blank). No motion is simulated: the
present position stays where it powered up.

A Protocol 2.0 servo whose Protocol Type is set to 1 (X series: "1: DYNAMIXEL Protocol 1.0") answers
these packets too, with its own control table (the 1.0 packet's one-byte address reaches the first
256 bytes); writing Protocol Type 2 back through Protocol 1.0 returns it to 2.0.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass
from typing import Callable

from ..protocol import servo as p2
from .faults import Replies
from .servo import VirtualServo

HEADER1 = b"\xff\xff"
BROADCAST_ID1 = 0xFE
PING1, READ1, WRITE1, RESET1, SYNC_WRITE1 = 0x01, 0x02, 0x03, 0x06, 0x83
KNOWN_INSTRUCTIONS1 = (0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08, 0x83, 0x92)
ERR_RANGE1, ERR_INSTRUCTION1 = 0x08, 0x40
BAUD_TOLERANCE = 0.03
_MAX_LENGTH = 0x8F  # the longest instruction packet an AX/MX buffer takes (143 bytes of parameters)

# (name, address, size, writable) shared by AX and MX; EEPROM is below address 24
_COMMON_ITEMS = (
    ("model_number", 0, 2, False), ("firmware_version", 2, 1, False), ("id", 3, 1, True),
    ("baud_rate", 4, 1, True), ("return_delay_time", 5, 1, True), ("cw_angle_limit", 6, 2, True),
    ("ccw_angle_limit", 8, 2, True), ("temperature_limit", 11, 1, True),
    ("min_voltage_limit", 12, 1, True), ("max_voltage_limit", 13, 1, True), ("max_torque", 14, 2, True),
    ("status_return_level", 16, 1, True), ("alarm_led", 17, 1, True), ("shutdown", 18, 1, True),
    ("torque_enable", 24, 1, True), ("led", 25, 1, True), ("goal_position", 30, 2, True),
    ("moving_speed", 32, 2, True), ("torque_limit", 34, 2, True), ("present_position", 36, 2, False),
    ("present_speed", 38, 2, False), ("present_load", 40, 2, False), ("present_voltage", 42, 1, False),
    ("present_temperature", 43, 1, False), ("registered", 44, 1, False), ("moving", 46, 1, False),
    ("lock", 47, 1, True), ("punch", 48, 2, True))
_AX_ITEMS = _COMMON_ITEMS + (
    ("cw_compliance_margin", 26, 1, True), ("ccw_compliance_margin", 27, 1, True),
    ("cw_compliance_slope", 28, 1, True), ("ccw_compliance_slope", 29, 1, True))
_MX_ITEMS = _COMMON_ITEMS + (
    ("multi_turn_offset", 20, 2, True), ("resolution_divider", 22, 1, True), ("d_gain", 26, 1, True),
    ("i_gain", 27, 1, True), ("p_gain", 28, 1, True), ("realtime_tick", 50, 2, False),
    ("goal_acceleration", 73, 1, True))
EEPROM_END = 24
_AX_BAUDS = {1: 1_000_000, 3: 500_000, 4: 400_000, 7: 250_000, 9: 200_000, 16: 115_200, 34: 57_600,
             103: 19_200, 207: 9_600}
_MX_BAUDS = {**_AX_BAUDS, 250: 2_250_000, 251: 2_500_000, 252: 3_000_000}
_AX_FACTORY = {"id": 1, "baud_rate": 1, "return_delay_time": 250, "cw_angle_limit": 0,
               "ccw_angle_limit": 1023, "temperature_limit": 70, "min_voltage_limit": 60,
               "max_voltage_limit": 140, "max_torque": 1023, "status_return_level": 2, "alarm_led": 36,
               "shutdown": 36, "cw_compliance_margin": 1, "ccw_compliance_margin": 1,
               "cw_compliance_slope": 32, "ccw_compliance_slope": 32, "punch": 32,
               "present_position": 512, "goal_position": 512, "present_voltage": 111,
               "present_temperature": 30}


@dataclass(frozen=True)
class Protocol1Model:
    """A Protocol 1.0 model: its number and name, items and factory values, baud rate values."""

    number: int
    name: str
    items: tuple[tuple[str, int, int, bool], ...]
    factory: dict[str, int]
    bauds: dict[int, int]
    firmware: int
    series: str = "Protocol 1.0"

    @property
    def size(self) -> int:
        return max(address + size for _, address, size, _ in self.items)

    def item(self, name: str) -> tuple[int, int, bool]:
        for item, address, size, writable in self.items:
            if item == name:
                return address, size, writable
        raise KeyError(f"{self.name} has no item {name!r}")


PROTOCOL1_MODELS: dict[int, Protocol1Model] = {m.number: m for m in (
    Protocol1Model(12, "AX-12A", _AX_ITEMS, _AX_FACTORY, _AX_BAUDS, 24),
    Protocol1Model(18, "AX-18A", _AX_ITEMS, {**_AX_FACTORY, "temperature_limit": 75, "max_torque": 983},
                   _AX_BAUDS, 24),
    Protocol1Model(29, "MX-28", _MX_ITEMS,
                   {**{k: v for k, v in _AX_FACTORY.items() if "compliance" not in k},
                    "baud_rate": 34, "ccw_angle_limit": 4095, "temperature_limit": 80,
                    "max_voltage_limit": 160, "punch": 0, "p_gain": 32, "resolution_divider": 1,
                    "present_position": 2048, "goal_position": 2048, "present_voltage": 120},
                   _MX_BAUDS, 41),
)}
"""Protocol 1.0 models by number; kept apart from the handler's control table."""


def protocol1_model(text: str | int) -> Protocol1Model | None:
    """The Protocol 1.0 model of a number or a name (case-insensitive; "MX-28(1.0)" as well as
    "MX-28"), or None."""
    key = str(text).strip().lower()
    for model in PROTOCOL1_MODELS.values():
        if key in (str(model.number), model.name.lower(), f"{model.name.lower()}(1.0)"):
            return model
    return None


def checksum(body: bytes | bytearray) -> int:
    """Protocol 1.0 checksum of ID, LEN, INST/ERROR and the parameters."""
    return ~sum(body) & 0xFF


def build_status1(servo_id: int, error: int, params: bytes = b"") -> bytes:
    body = bytes([servo_id, len(params) + 2, error]) + bytes(params)
    return HEADER1 + body + bytes([checksum(body)])


def build_instruction1(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    body = bytes([servo_id, len(params) + 2, instruction]) + bytes(params)
    return HEADER1 + body + bytes([checksum(body)])


class Protocol1Parser:
    """Incremental reader of Protocol 1.0 instruction packets, resynchronising after noise as a
    servo's receiver does. A Protocol 2.0 header (``FF FF FD 00``) reads as ID 253 with length 0
    and is skipped, so 2.0 traffic passes by."""

    def __init__(self) -> None:
        self._buf = bytearray()

    @property
    def pending(self) -> int:
        return len(self._buf)

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[p2.Packet]:
        buf = self._buf
        buf += data
        out: list[p2.Packet] = []
        pos = 0
        while True:
            start = buf.find(HEADER1, pos)
            if start < 0:
                pos = len(buf) - 1 if buf.endswith(b"\xff") else len(buf)
                break
            pos = start
            if len(buf) - pos < 6:
                break
            servo_id, length, inst = buf[pos + 2], buf[pos + 3], buf[pos + 4]
            if servo_id == 0xFF or not 2 <= length <= _MAX_LENGTH or inst not in KNOWN_INSTRUCTIONS1:
                pos += 1
                continue
            end = pos + 4 + length
            if end > len(buf):
                break
            if checksum(buf[pos + 2:end - 1]) != buf[end - 1]:
                pos += 1  # no reply to a bad checksum: it may be another protocol's bytes
                continue
            out.append(p2.Packet(servo_id, inst, bytes(buf[pos + 5:end - 1]), end - pos))
            pos = end
        del buf[:pos]
        return out


class Protocol1Servo:
    """A Protocol 1.0 servo: a register file with its model's items; the bus's servo interface
    (``id``, ``baudrate``, ``silent``, ``model``, ``read``/``write`` by name, ``state``)."""

    speaks_protocol_2 = False
    partner = None

    def __init__(self, model: Protocol1Model, servo_id: int) -> None:
        self.model = model
        self.baud_rates = dict(model.bauds)
        self.silent = False
        self.eeprom_changed = False
        self.regs = bytearray(model.size)
        self._factory()
        self.write("id", servo_id)
        self.eeprom_changed = False

    def _factory(self) -> None:
        self.regs[:] = bytes(len(self.regs))
        self.write("model_number", self.model.number)
        self.write("firmware_version", self.model.firmware)
        for name, value in self.model.factory.items():
            self.write(name, value)
        self.write("torque_limit", self.read("max_torque"))

    def read(self, name: str) -> int:
        address, size, _ = self.model.item(name)
        return int.from_bytes(self.regs[address:address + size], "little")

    def write(self, name: str, value: int) -> None:
        """Set an item with no checks (a test's way to set a state a host could not)."""
        address, size, _ = self.model.item(name)
        self.regs[address:address + size] = int(value).to_bytes(size, "little")

    @property
    def id(self) -> int:
        return self.regs[3]

    @property
    def baudrate(self) -> int:
        """The line speed of its Baud Rate register: the e-Manual's nominal rate where it lists
        the value, else 2,000,000 / (value + 1)."""
        value = self.regs[4]
        return self.baud_rates.get(value, 2_000_000 // (value + 1))

    def hears(self, line_bps: int | None) -> bool:
        """Whether it decodes a host at ``line_bps`` (None: any speed): within 3 % of its actual rate."""
        actual = 2_000_000 / (self.regs[4] + 1)
        return line_bps is None or abs(line_bps - actual) <= BAUD_TOLERANCE * line_bps

    @property
    def return_delay_s(self) -> float:
        return self.regs[5] * 2e-6

    @property
    def status_return_level(self) -> int:
        return self.regs[16]

    def host_read(self, address: int, length: int) -> tuple[int, bytes]:
        if length < 1 or address + length > len(self.regs):
            return ERR_RANGE1, b""
        return 0, bytes(self.regs[address:address + length])

    def host_write(self, address: int, data: bytes) -> int:
        """A host's write: refused whole (Range Error) when it touches a read-only item, runs past
        the table, holds an ID or baud value out of range or hits EEPROM while Lock is 1."""
        end = address + len(data)
        if not data or end > len(self.regs):
            return ERR_RANGE1
        new = bytearray(self.regs)
        new[address:end] = data
        for _, item_address, size, writable in self.model.items:
            touched = item_address < end and address < item_address + size
            if touched and not writable:
                return ERR_RANGE1
        if new[3] > 253 or (address < EEPROM_END and self.regs[47]):
            return ERR_RANGE1
        if new[:EEPROM_END] != self.regs[:EEPROM_END]:
            self.eeprom_changed = True
        self.regs[:] = new
        return 0

    def factory_reset(self) -> None:
        self._factory()
        self.eeprom_changed = True

    def state(self) -> dict:
        """Its EEPROM, for the bus's ``--state`` file."""
        return {"protocol": 1, "model": self.model.number, "eeprom": bytes(self.regs[:EEPROM_END]).hex()}

    @classmethod
    def from_state(cls, entry: dict) -> "Protocol1Servo":
        servo = cls(PROTOCOL1_MODELS[int(entry["model"])], 1)
        eeprom = bytes.fromhex(entry["eeprom"])[:EEPROM_END]
        servo.regs[:len(eeprom)] = eeprom
        servo.write("model_number", servo.model.number)
        servo.write("torque_limit", servo.read("max_torque"))
        return servo


class _SwitchedTo1:
    """A Protocol 2.0 servo set to Protocol Type 1, seen through the 1.0 servo interface: its
    control table, any refused access answered with the Range Error bit."""

    def __init__(self, servo: VirtualServo, now: float) -> None:
        self.servo, self.now = servo, now

    @property
    def id(self) -> int:
        return self.servo.id

    @property
    def return_delay_s(self) -> float:
        return self.servo.return_delay_s

    @property
    def status_return_level(self) -> int:
        return self.servo.status_return_level

    def host_read(self, address: int, length: int) -> tuple[int, bytes]:
        error, data = self.servo.host_read(address, length, self.now)
        return (ERR_RANGE1, b"") if error else (0, data)

    def host_write(self, address: int, data: bytes) -> int:
        return ERR_RANGE1 if self.servo.host_write(address, data, self.now) & 0x7F else 0

    def factory_reset(self) -> None:
        self.servo.factory_reset(0xFF, self.now)


class Protocol1Instructions:
    """What the Protocol 1.0 servos of the bus do with a 1.0 packet: PING, READ, WRITE, RESET
    (factory values) and SYNC WRITE; other instructions get the Instruction Error bit. ``servos``
    is the bus's list: its Protocol 2.0 servos hear a 1.0 packet only when set to Protocol Type 1."""

    def __init__(self, servos: list, stats: collections.Counter[str], clock: Callable[[], float]) -> None:
        self._servos = servos
        self.stats = stats
        self.clock = clock
        self.line_bps: int | None = None

    def _hearing(self, packet_id: int) -> list:
        alive = [_one_point_o(s, self.line_bps, self.clock) for s in self._servos if not s.silent]
        hearing = [s for s in alive if s is not None]
        if packet_id == BROADCAST_ID1:
            return hearing
        return [s for s in hearing if s.id == packet_id]

    def execute(self, packet: p2.Packet) -> Replies:
        self.stats["protocol1_instructions"] += 1
        if packet.instruction == SYNC_WRITE1:
            self._sync_write(packet.params)
            return []
        out: Replies = []
        for servo in self._hearing(packet.packet_id):
            before = (servo.id, servo.status_return_level)
            error, data = _ONE.get(packet.instruction, _unknown)(servo, packet.params)
            if _answers(packet, before[1]):
                out.append((servo.return_delay_s, build_status1(before[0], error, data)))
        return out

    def _sync_write(self, prm: bytes) -> None:
        if len(prm) < 2:
            return
        address, length = prm[0], prm[1]
        for k in range(2, len(prm) - length, 1 + length):
            for servo in self._hearing(prm[k]):
                servo.host_write(address, prm[k + 1:k + 1 + length])


def _one_point_o(servo: Protocol1Servo | VirtualServo, line_bps: int | None,
                 clock: Callable[[], float]) -> Protocol1Servo | _SwitchedTo1 | None:
    """The servo as a Protocol 1.0 listener at ``line_bps`` (None: it does not hear the packet)."""
    if isinstance(servo, Protocol1Servo):
        return servo if servo.hears(line_bps) else None
    if servo.speaks_protocol_2 or not (line_bps is None or servo.baudrate == line_bps):
        return None
    return _SwitchedTo1(servo, clock())


def _answers(packet: p2.Packet, level: int) -> bool:
    """Whether a status packet goes back: never to a broadcast, else as Status Return Level says."""
    if packet.packet_id == BROADCAST_ID1:
        return False
    return packet.instruction == PING1 or level == 2 or (level == 1 and packet.instruction == READ1)


def _read(servo: Protocol1Servo, prm: bytes) -> tuple[int, bytes]:
    return servo.host_read(prm[0], prm[1]) if len(prm) == 2 else (ERR_RANGE1, b"")


def _write(servo: Protocol1Servo, prm: bytes) -> tuple[int, bytes]:
    return (servo.host_write(prm[0], prm[1:]) if len(prm) >= 2 else ERR_RANGE1), b""


def _reset(servo: Protocol1Servo, prm: bytes) -> tuple[int, bytes]:
    servo.factory_reset()
    return 0, b""


def _unknown(servo: Protocol1Servo, prm: bytes) -> tuple[int, bytes]:
    return ERR_INSTRUCTION1, b""


_ONE: dict[int, Callable[[Protocol1Servo, bytes], tuple[int, bytes]]] = {
    PING1: lambda servo, prm: (0, b""), READ1: _read, WRITE1: _write, RESET1: _reset,
}
