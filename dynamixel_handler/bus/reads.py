"""Reads of ``DynamixelBus``: ping, (fast) sync read, left on the wire or waited for, bulk read,
and the scan (broadcast ping, or one ping per ID)."""
from __future__ import annotations

import time
from typing import Iterable, Mapping

import serial

from ..protocol import host as p
from ..protocol.framers import FRAMERS, PROTOCOL2, Framer
from .group_read import GroupRead, check_id, unique_ids
from .result import Failure, Result
from .transport import Transport

#: Scans of more IDs than this use one broadcast ping instead of a ping per ID.
BROADCAST_SCAN_MIN_IDS = 5
#: Time slot each ID gets in a broadcast ping reply train, on top of its packet's wire time.
BROADCAST_PING_SLOT_MS = 3.0
PING_REPLY_PARAMS = 3
#: sync read packets kept built (the loop asks for the same few reads over and over)
_INT_ONLY = {int}
_PACKET_CACHE_SIZE = 64


class Reads:
    """Pings and group reads over one ``Transport``; keeps the sync read packets it built."""

    def __init__(self, transport: Transport) -> None:
        self._t = transport
        #: firmware version seen in Protocol 2.0 ping replies
        self.firmware_versions: dict[int, int] = {}
        # sync read packets and their (id, size) list by (address, length, ids as given, fast)
        self._packets: dict[tuple[int, int, tuple[int, ...], bool], tuple[bytes, tuple[tuple[int, int], ...]]] = {}

    def ping(self, dxl_id: int, retries: int | None = None, *, framer: Framer) -> Result[int | None]:
        """Model number of ``dxl_id`` (None and why if it does not answer). A Protocol 1.0 ping's
        status carries nothing: the model number is read at address 0 after it. Its firmware is not
        recorded: where it lives depends on the model (address 2 on the Protocol 1.0 models, 6 on an
        X set to Protocol Type 1), so it is read as the model's ``firmware_version`` item."""
        dxl_id = check_id(dxl_id)
        t = self._t
        with t.transaction() as tx:
            status = t.unicast(dxl_id, framer.PING, b"", framer.ping_params(), retries, framer=framer)
            if status is None or status.refused:
                return tx.failed(None, f"ping ID {dxl_id}", status, framer=framer)
            identity = framer.identity(status.params)
            if identity is not None:
                tx.ok(1, 1)
                number, self.firmware_versions[dxl_id] = identity
                return Result(number)
            status = t.unicast(dxl_id, framer.READ, framer.read_params(0, 2), 2, retries, framer=framer)
            if status is None or status.refused:
                return Result(None, Failure.ANSWERS_PING_ONLY, tx.fail(
                    f"ping ID {dxl_id}: answers a Protocol 1.0 ping but not a read of its model number "
                    "(Status Return Level 0?)"))
            tx.ok(1, 1)
            return Result(status.params[0] | (status.params[1] << 8))

    def start_sync_read(self, address: int, length: int, ids: Iterable[int], fast: bool = False,
                        *, protocol: int) -> GroupRead:
        """Send a sync read and return at once; ``result()`` of the returned read waits for the
        replies (same result as :meth:`sync_read`). Meanwhile the caller may do work that needs no
        bus; any other transaction first waits for this read to end, so none is ever lost.
        """
        framer = FRAMERS[protocol]
        if not framer.sync_read:
            return self._read_without_sync_read(address, length, ids, fast, framer)
        given = ids if isinstance(ids, tuple) else tuple(ids)
        # plain ints only as a key: 1.0 or True would find the entry of 1 and skip the ID check
        key = (address, length, given, fast) if set(map(type, given)) == _INT_ONLY else None
        cached = self._packets.get(key) if key is not None else None
        if cached is None:
            order = tuple(unique_ids(given))  # raises on a bad ID before anything is cached
            if not order:
                return GroupRead.finished({})
            instruction = p.FAST_SYNC_READ if fast else p.SYNC_READ
            packet = p.build_instruction(p.BROADCAST_ID, instruction, p.sync_read_params(address, length, order))
            cached = (packet, tuple((i, length) for i in order))
            if key is not None:
                if len(self._packets) >= _PACKET_CACHE_SIZE:
                    self._packets.clear()
                self._packets[key] = cached
        packet, expected = cached
        return self._t.start_group_read(packet, list(expected), fast,
                                        f"{'fast ' if fast else ''}sync read @{address}x{length}", framer=framer)

    def _read_without_sync_read(self, address: int, length: int, ids: Iterable[int], bulk: bool,
                                framer: Framer) -> GroupRead:
        """A group read in a protocol without Sync Read (1.0): one Bulk Read (``bulk``: MX and EX
        take it), or one read each."""
        if bulk:
            return self.bulk_read({i: (address, length) for i in unique_ids(ids)}, framer=framer)
        return self._read_each(address, length, ids, framer)

    def _read_each(self, address: int, length: int, ids: Iterable[int], framer: Framer) -> GroupRead:
        """The same item of each servo, one read instruction each (a protocol without Sync Read);
        each sent once more on silence (a late reply is not taken for a silent servo, and a silent
        one costs two reply waits, not the bus's retry count)."""
        t = self._t
        data: dict[int, bytes] = {}
        errors: dict[int, int] = {}
        for dxl_id in unique_ids(ids):
            with t.transaction() as tx:
                status = t.unicast(dxl_id, framer.READ, framer.read_params(address, length), length,
                                   min(1, t.retry_num), framer=framer)
                if status is not None and not status.refused:
                    tx.ok(1, 1)
                    data[dxl_id], errors[dxl_id] = status.params, status.error
        read = GroupRead.finished(data)
        read.errors = errors
        if not data and ids:
            read.failure, read.why = Failure.NOBODY_ANSWERED, f"read @{address}x{length}: no servo answered"
        return read

    def bulk_read(self, requests: Mapping[int, tuple[int, int]], fast: bool = False,
                  *, framer: Framer) -> GroupRead:
        """Different ``(address, size)`` per servo (IDs checked) in one instruction, on the wire;
        in Protocol 1.0 (``framer``) each servo answers with a status of its own, after the one
        listed before it."""
        order = list(requests)
        if not order:
            return GroupRead.finished({})
        packet, fast, what = framer.bulk_read([(i, requests[i][0], requests[i][1]) for i in order], fast)
        return self._t.start_group_read(packet, [(i, requests[i][1]) for i in order], fast, what, framer=framer)

    def scan(self, ids: Iterable[int], broadcast: bool | None = None) -> dict[int, int]:
        """``{id: model_number}`` of the servos among ``ids`` that answer a ping.

        Wide ranges use one broadcast ping (replies come in ID order, so its wait grows
        with the highest ID); if that reply train was garbled (collisions, CRC errors)
        the IDs not found are pinged one by one. Unicast scan pings are not retried.
        """
        wanted = sorted(unique_ids(ids))
        if not wanted:
            return {}
        if broadcast is None:
            broadcast = len(wanted) >= BROADCAST_SCAN_MIN_IDS
        found: dict[int, int] = {}
        garbled = True
        if broadcast:
            found, garbled = self._broadcast_ping(wanted)
        if garbled:
            for dxl_id in wanted:
                if dxl_id not in found:
                    model = self.ping(dxl_id, retries=0, framer=PROTOCOL2).value  # a scan: Protocol 2.0
                    if model is not None:
                        found[dxl_id] = model
        return dict(sorted(found.items()))

    def _take_ping(self, status: p.Status, wanted: list[int], found: dict[int, int]) -> bool:
        """Note one reply of a broadcast ping in ``found``; True when its ID had answered already
        (two servos share it: the second reply is counted as discarded)."""
        t = self._t
        if status.dxl_id in found:
            t.stats.discarded_bytes += p.STATUS_OVERHEAD + len(status.params)
            return True
        if len(status.params) == PING_REPLY_PARAMS and status.dxl_id in wanted:
            t.rx.note_status(status, framer=PROTOCOL2)
            self.firmware_versions[status.dxl_id] = status.params[2]
            found[status.dxl_id] = status.params[0] | (status.params[1] << 8)
        return False

    def _broadcast_ping(self, wanted: list[int]) -> tuple[dict[int, int], bool]:
        t = self._t
        rx, stats = t.rx, t.stats
        packet = p.build_instruction(p.BROADCAST_ID, p.PING)
        reply_bytes = p.STATUS_OVERHEAD + PING_REPLY_PARAMS
        slots = (max(wanted) + 1) * (reply_bytes * t.port.tx_ms_per_byte + BROADCAST_PING_SLOT_MS)
        wait_ms = rx.reply_timeout_ms(len(packet), 0) + slots
        found: dict[int, int] = {}
        garbled_ids = False
        with t.transaction() as tx:
            stream = p.StatusStream()
            if not t.send(packet):
                tx.fail(f"broadcast ping: {t.why(None)[1]}")
                return {}, False
            rx.last_timeout_ms = wait_ms
            deadline = time.monotonic() + wait_ms / 1000.0
            try:
                while len(found) < len(wanted):
                    data = t.port.read_until(deadline)
                    if not data:
                        break
                    stats.bytes_rx += len(data)
                    for status in stream.feed(data):
                        garbled_ids = self._take_ping(status, wanted, found) or garbled_ids
            except (OSError, serial.SerialException) as exc:
                rx.lose(exc)
            garbled = garbled_ids or bool(stream.crc_errors or stream.discarded_bytes or stream.pending_bytes)
            stats.crc_errors += stream.crc_errors
            stats.discarded_bytes += stream.discarded_bytes + stream.pending_bytes
            if found:
                tx.ok(1, 1)
            else:
                tx.fail("broadcast ping: no servo answered")
            return found, garbled
