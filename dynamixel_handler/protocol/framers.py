"""A framer per protocol: how the host builds an instruction and reads the statuses of the servos
that speak it. The bus layer sends every instruction through the framer of its protocol
(``FRAMERS[op.protocol]``), so one line carries Protocol 1.0 and 2.0 servos side by side; what
differs between the two (address and length widths, CRC or checksum, stuffing, which instructions
exist, what the error byte means) lives here and in the two wire modules, nowhere else.

``Protocol2`` frames with :mod:`.host`; ``Protocol1`` with :mod:`.protocol1`.
"""
from __future__ import annotations

from typing import Any, Iterable, Protocol

from . import host as p2
from . import protocol1 as p1


class StatusReader(Protocol):
    """An incremental status reader: ``feed`` gives the complete statuses (each with ``dxl_id``,
    ``error``, ``params``, ``refused``), counting what it skipped."""

    crc_errors: int
    discarded_bytes: int

    @property
    def pending_bytes(self) -> int: ...
    def feed(self, data: bytes) -> list[Any]: ...


class Framer(Protocol):
    """One protocol's framing, as the host uses it."""

    #: 1 or 2
    version: int
    #: "Protocol 2.0", "Protocol 1.0": how lines name it
    name: str
    broadcast_id: int
    #: a broadcast ping answered by every servo in turn (else: one ping per ID)
    broadcast_ping: bool
    #: a Sync Read instruction (else: a Bulk Read where the model takes it, or one read each)
    sync_read: bool
    #: each status's error byte carries the servo's state of the moment (overload, heat, ...),
    #: kept with the replies of a group read
    state_in_error_byte: bool
    #: a ping's status carries the servo's model number and firmware version (else: the model number
    #: is read at address 0 and the firmware is an item of its model)
    ping_identity: bool
    #: Factory Reset takes what to keep (its ID, its baud rate); else it resets everything
    reset_option: bool
    #: bytes of a status packet without parameters
    status_overhead: int
    #: instruction codes
    PING: int
    READ: int
    WRITE: int
    REG_WRITE: int
    ACTION: int
    REBOOT: int
    FACTORY_RESET: int
    SYNC_WRITE: int
    #: the Clear instruction (multi-turn, error clear); None: the protocol has none
    CLEAR: int | None

    def instruction(self, dxl_id: int, instruction: int, params: bytes = b"") -> bytes: ...
    def statuses(self) -> StatusReader: ...
    def error_text(self, error: int) -> str: ...
    def read_params(self, address: int, size: int) -> bytes: ...
    def write_params(self, address: int, data: bytes) -> bytes: ...
    def sync_write_params(self, address: int, length: int, data: Iterable[tuple[int, bytes]]) -> bytes: ...
    def factory_reset_params(self, option: int) -> bytes: ...
    def ping_params(self) -> int: ...
    def corrupted(self, error: int) -> bool: ...
    def identity(self, params: bytes) -> tuple[int, int] | None: ...
    def bulk_read(self, requests: list[tuple[int, int, int]], fast: bool) -> tuple[bytes, bool, str]: ...


class Protocol2:
    """Protocol 2.0: two-byte addresses and lengths, CRC-16, byte stuffing; a ping answers with
    the model number and firmware (3 parameters)."""

    version = 2
    name = "Protocol 2.0"
    broadcast_id = p2.BROADCAST_ID
    broadcast_ping = True
    sync_read = True
    state_in_error_byte = False
    ping_identity = True
    reset_option = True
    status_overhead = p2.STATUS_OVERHEAD
    PING, READ, WRITE, REG_WRITE, ACTION = p2.PING, p2.READ, p2.WRITE, p2.REG_WRITE, p2.ACTION
    REBOOT, FACTORY_RESET, SYNC_WRITE = p2.REBOOT, p2.FACTORY_RESET, p2.SYNC_WRITE
    CLEAR: int | None = p2.CLEAR

    @staticmethod
    def instruction(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
        return p2.build_instruction(dxl_id, instruction, params)

    @staticmethod
    def statuses() -> p2.StatusStream:
        return p2.StatusStream()

    @staticmethod
    def error_text(error: int) -> str:
        return p2.error_text(error)

    @staticmethod
    def read_params(address: int, size: int) -> bytes:
        return p2.u16(address) + p2.u16(size)

    @staticmethod
    def write_params(address: int, data: bytes) -> bytes:
        return p2.u16(address) + bytes(data)

    @staticmethod
    def sync_write_params(address: int, length: int, data: Iterable[tuple[int, bytes]]) -> bytes:
        return p2.sync_write_params(address, length, data)

    @staticmethod
    def factory_reset_params(option: int) -> bytes:
        return bytes([option])

    @staticmethod
    def ping_params() -> int:
        return 3

    @staticmethod
    def corrupted(error: int) -> bool:
        """The servo got the packet corrupted (CRC error): sending it again may help."""
        return (error & 0x7F) == p2.ERR_CRC

    @staticmethod
    def identity(params: bytes) -> tuple[int, int] | None:
        """A ping status's model number and firmware version."""
        return params[0] | (params[1] << 8), params[2]

    @staticmethod
    def bulk_read(requests: list[tuple[int, int, int]], fast: bool) -> tuple[bytes, bool, str]:
        """The (Fast) Bulk Read of (ID, address, size) each: packet, whether fast, its name."""
        instruction = p2.FAST_BULK_READ if fast else p2.BULK_READ
        packet = p2.build_instruction(p2.BROADCAST_ID, instruction, p2.bulk_read_params(requests))
        return packet, fast, f"{'fast ' if fast else ''}bulk read"


class Protocol1:
    """Protocol 1.0: one-byte addresses and lengths, a checksum, no stuffing; a ping's status has
    no parameters (the model number is read at address 0); the reset takes no option."""

    version = 1
    name = "Protocol 1.0"
    broadcast_id = p1.BROADCAST_ID
    broadcast_ping = False
    sync_read = False
    state_in_error_byte = True
    ping_identity = False
    reset_option = False
    status_overhead = p1.STATUS_OVERHEAD
    PING, READ, WRITE, REG_WRITE, ACTION = p1.PING, p1.READ, p1.WRITE, p1.REG_WRITE, p1.ACTION
    REBOOT, FACTORY_RESET, SYNC_WRITE = p1.REBOOT, p1.RESET, p1.SYNC_WRITE
    CLEAR: int | None = None

    @staticmethod
    def instruction(dxl_id: int, instruction: int, params: bytes = b"") -> bytes:
        return p1.build_instruction(dxl_id, instruction, params)

    @staticmethod
    def statuses() -> p1.StatusStream1:
        return p1.StatusStream1()

    @staticmethod
    def error_text(error: int) -> str:
        return p1.error_text(error)

    @staticmethod
    def read_params(address: int, size: int) -> bytes:
        return p1.read_params(address, size)

    @staticmethod
    def write_params(address: int, data: bytes) -> bytes:
        return p1.write_params(address, data)

    @staticmethod
    def sync_write_params(address: int, length: int, data: Iterable[tuple[int, bytes]]) -> bytes:
        return p1.sync_write_params(address, length, data)

    @staticmethod
    def factory_reset_params(option: int) -> bytes:
        return b""

    @staticmethod
    def ping_params() -> int:
        return 0

    @staticmethod
    def corrupted(error: int) -> bool:
        """The servo got the packet corrupted (checksum error): sending it again may help."""
        return bool(error & p1.ERR_CHECKSUM)

    @staticmethod
    def identity(params: bytes) -> tuple[int, int] | None:
        """None: a ping status has no parameters (the model number is read at address 0)."""
        return None

    @staticmethod
    def bulk_read(requests: list[tuple[int, int, int]], fast: bool) -> tuple[bytes, bool, str]:
        """The Bulk Read of (ID, address, size) each (MX, EX); no fast form: each servo answers
        with a status of its own, after the one listed before it."""
        packet = p1.build_instruction(p1.BROADCAST_ID, p1.BULK_READ, p1.bulk_read_params(requests))
        return packet, False, "bulk read (Protocol 1.0)"


PROTOCOL1, PROTOCOL2 = Protocol1(), Protocol2()
#: the framer of each protocol version
FRAMERS: dict[int, Framer] = {1: PROTOCOL1, 2: PROTOCOL2}
