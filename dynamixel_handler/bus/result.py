"""``Result``: what a bus instruction returned, with why it failed, as one value (no shared "last
failure" to read afterwards, which another thread's call may have changed meanwhile), and
``Failure``, the kinds of failure a caller may act on."""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T", covariant=True)


class Failure(enum.Enum):
    """Why an instruction failed, as a kind a caller can act on; the text of ``Result.why`` adds
    the detail (which instruction, which servo, how long was waited)."""

    #: nothing came back within the reply wait
    NO_REPLY = "no reply"
    #: the servo answered with an error in its status (range, access, CRC, instruction ...)
    REFUSED = "refused"
    #: the device went away mid-run (unplugged, hung up): failing fast until it is reopened
    DEVICE_LOST = "device lost"
    #: the port is closed
    PORT_CLOSED = "port closed"
    #: a group read that no servo answered
    NOBODY_ANSWERED = "no servo answered"
    #: not sent: the servo's model has no such item
    NO_SUCH_ITEM = "no such item"
    #: not sent: the handler holds it back (a reboot asked for again too soon)
    HELD_BACK = "held back"
    #: a Protocol 1.0 servo answered the ping but not the read of its model number (Status Return
    #: Level 0: it answers nothing but pings)
    ANSWERS_PING_ONLY = "answers a ping only"
    #: not sent: the servo's protocol has no such instruction (a Clear in Protocol 1.0)
    NOT_IN_PROTOCOL = "not in the protocol"

    def __str__(self) -> str:
        """The kind in words, as a log line says it ("no reply", not "Failure.NO_REPLY")."""
        return self.value


@dataclass(frozen=True, slots=True)
class Result(Generic[T]):
    """``value``: what the instruction gives (data, a model number, True) or its failure value
    (None, False); ``failure``: the kind of failure, None when it worked; ``why``: that failure in
    words for a log line ("" when it worked); ``error``: the status error byte that came with the
answer or the refusal. True in a condition when it worked."""

    value: T
    failure: Failure | None = None
    why: str = ""
    #: the error byte of the servo's status (a refusal's reason; Protocol 1.0: its state too), None
    #: without one (no reply, a broadcast, a group read)
    error: int | None = None

    @property
    def ok(self) -> bool:
        return self.failure is None

    def __bool__(self) -> bool:
        return self.failure is None
