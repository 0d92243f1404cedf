"""The wire limit of one loop: how fast a perfect host could run the benchmark cycle.

One cycle is what the benchmark asks of every contender: a Sync Write of Goal Position to N
servos, then a (Fast) Sync Read of Present Current + Velocity + Position (X series: address 126,
10 bytes). The packets are built byte for byte with the product's own packet builders (instruction
side: ``dynamixel_handler.protocol.host``; status side: ``dynamixel_handler.protocol.servo``), so
header, length, CRC and byte stuffing are exact for the values used.

Time of a byte on the wire: 1 start + 8 data + 1 stop bit = 10 bits / baud. The adapter's latency
is paid once per transaction that the host waits on (the read): a broadcast Sync Write has no
reply, so the host goes on as soon as the bytes are handed to the adapter. This is also how the
virtual bus times a transaction, so the virtual bus cannot run faster than this limit.
"""
from __future__ import annotations

from dataclasses import dataclass

from dynamixel_handler.protocol import host, servo

#: X series: Present Current (126, 2) + Present Velocity (128, 4) + Present Position (132, 4)
PRESENT_ADDRESS, PRESENT_LENGTH = 126, 10
#: X series: Goal Position (116, 4)
GOAL_ADDRESS, GOAL_LENGTH = 116, 4


@dataclass(frozen=True)
class Cycle:
    """Bytes of one benchmark cycle and the time they take on the wire."""

    write_bytes: int        # Sync Write instruction (no reply)
    read_bytes: int         # (Fast) Sync Read instruction
    reply_bytes: int        # status packet(s) answering the read
    replied_transactions: int
    baudrate: int
    latency_s: float

    @property
    def total_bytes(self) -> int:
        return self.write_bytes + self.read_bytes + self.reply_bytes

    @property
    def seconds(self) -> float:
        return self.total_bytes * 10.0 / self.baudrate + self.replied_transactions * self.latency_s

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.seconds


def _present_bytes(position: int = 2048, velocity: int = 0, current: int = 0) -> bytes:
    return (current.to_bytes(2, "little", signed=True) + velocity.to_bytes(4, "little", signed=True)
            + position.to_bytes(4, "little", signed=True))


def cycle(n_servos: int, baudrate: int, latency_s: float, fast_read: bool, first_id: int = 1) -> Cycle:
    """The exact packets of one cycle over IDs ``first_id .. first_id + n_servos - 1``."""
    ids = list(range(first_id, first_id + n_servos))
    goal = (2048).to_bytes(GOAL_LENGTH, "little")
    write = host.build_instruction(host.BROADCAST_ID, host.SYNC_WRITE,
                                   host.sync_write_params(GOAL_ADDRESS, GOAL_LENGTH, [(i, goal) for i in ids]))
    inst = host.FAST_SYNC_READ if fast_read else host.SYNC_READ
    read = host.build_instruction(host.BROADCAST_ID, inst, host.sync_read_params(PRESENT_ADDRESS, PRESENT_LENGTH, ids))
    data = _present_bytes()
    if fast_read:
        chain = n_servos * (4 + PRESENT_LENGTH)  # error + id + data + crc per servo
        replies = [servo.build_fast_status([(0, i, data) for i in ids], chain)]
    else:
        replies = [servo.build_status(i, 0, data) for i in ids]
    return Cycle(len(write), len(read), sum(len(r) for r in replies), 1, baudrate, latency_s)


if __name__ == "__main__":
    for fast in (False, True):
        for n in (1, 4, 12, 30):
            c = cycle(n, 1_000_000, 0.0, fast)
            print(f"{'fast' if fast else 'sync'} N={n:2d}: write {c.write_bytes} B, read {c.read_bytes} B, "
                  f"replies {c.reply_bytes} B -> {1e3 * c.seconds:.3f} ms at 1 Mbps")
