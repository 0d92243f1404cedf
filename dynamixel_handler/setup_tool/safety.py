"""Critical steps: what Ctrl-C (SIGINT), SIGTERM and SIGHUP may not cut in half, and the state each
touched servo is left in.

A *critical step* runs with those signals held (``with held():``): one that arrives is noted, the
step finishes (torque off -> write -> read back -> goal := present -> torque restored; a baud, ID or
protocol change and finding the servo again), then the tool stops with :class:`Interrupted` (exit
code 130), whose one line names every touched servo: ID, rate, torque, what was written. Outside a
step a signal stops the tool at once (``KeyboardInterrupt``; :func:`stopped` makes the same line).

Interface (for every verb that writes, ``restore`` included):

* :func:`install` once, after the bus is open: SIGTERM/SIGHUP stop the tool as Ctrl-C does.
* :func:`checked_write` the one write of an item: only when it differs, torque rule
  (:class:`TorqueOn` unless ``torque_off``), signals held, read back, the journal kept.
* :func:`held` for another critical step (a reboot, a factory reset); :data:`JOURNAL` to note
  what such a step did (:meth:`Journal.touch`).
"""
from __future__ import annotations

import os
import signal
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import FrameType
from typing import Any, Callable, Iterator, Protocol, TypeVar

from ..control_table import Item, Model
from .errors import BadArguments, StepFailed
from .items import show_value
from .per_protocol import tool_protocol

__all__ = ["Interrupted", "TorqueOn", "Journal", "JOURNAL", "install", "held", "checked_write", "stopped"]

#: signals that stop the tool (held during a critical step)
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: test hook: pause before the bus instruction after the Nth (until a signal comes); unset: no hook
PAUSE_ENV = "DXL_SETUP_TEST_PAUSE_AFTER"


class Interrupted(StepFailed):
    """A signal stopped the tool (after the critical step in progress): exit code 130."""

    exit_code = 130


class TorqueOn(BadArguments):
    """An item that needs torque off, on a servo whose torque is on, without ``--torque-off``."""


def reboot_consent(holding: set[int], count: int, torque_off: bool, confirm: Callable[[str], None]) -> None:
    """The owner's word for a reboot of ``count`` servos of which ``holding`` hold their load:
    TorqueOn (nothing rebooted) without ``torque_off``, else asked (``confirm``, which returns
    when the answer is yes). On the bus and through a running node alike."""
    if not holding:
        return
    ids = ", ".join(map(str, sorted(holding)))
    if not torque_off:
        raise TorqueOn(f"ID {ids}: torque is on and a reboot turns it off, which lets go of the load it holds: refused, "
                       "nothing rebooted (give --torque-off to reboot and turn torque back on with the goal where the "
                       "servo is)")
    confirm(f"reboot {count} servo(s); ID {ids} hold their load (torque on): torque goes off for the reboot and comes "
            "back on with the goal where each one is?")


class _Servo(Protocol):
    dxl_id: int
    model: Model

    @property
    def bus(self) -> Any: ...
    @property
    def who(self) -> str: ...
    def item(self, name: str) -> Item: ...
    def read(self, name: str) -> int: ...
    def write(self, name: str, raw: int) -> None: ...
    def torque_on(self) -> bool: ...
    def torque_on_in_place(self) -> None: ...


S = TypeVar("S", bound=_Servo)


@dataclass
class Touched:
    """One servo the run has written to, and the state it is in now."""

    dxl_id: int
    model: str
    baudrate: int
    #: "on", "off", or a sentence ("off (it was on)")
    torque: str
    done: list[str] = field(default_factory=list)

    def line(self) -> str:
        done = "; ".join(self.done) if self.done else "nothing written"
        return f"ID {self.dxl_id} ({self.model}) at {self.baudrate} bps, torque {self.torque}: {done}"


class Journal:
    """Every servo the run touched (in order) and the one line that names their states."""

    def __init__(self) -> None:
        self.servos: list[Touched] = []

    def touch(self, dxl_id: int, model: str, baudrate: int, torque: str) -> Touched:
        """The entry of the servo now at ``dxl_id`` / ``baudrate`` (a new one the first time)."""
        for entry in self.servos:
            if (entry.dxl_id, entry.baudrate, entry.model) == (dxl_id, baudrate, model):
                return entry
        entry = Touched(dxl_id, model, baudrate, torque)
        self.servos.append(entry)
        return entry

    def as_list(self) -> list[dict[str, object]]:
        """The touched servos for JSON: ``id``, ``model``, ``baudrate``, ``torque``, ``done``."""
        return [{"id": t.dxl_id, "model": t.model, "baudrate": t.baudrate, "torque": t.torque, "done": list(t.done)}
                for t in self.servos]

    def state(self) -> str:
        if not self.servos:
            return "nothing was written"
        return "state: " + " | ".join(entry.line() for entry in self.servos)


JOURNAL = Journal()


class _Signals:
    depth = 0
    pending: int | None = None
    #: signals received in the whole run (the test hook waits for the next one)
    count = 0
    last = "SIGINT"


def _name(signum: int) -> str:
    return signal.Signals(signum).name


def _stop(signum: int, _frame: FrameType | None) -> None:
    _Signals.count += 1
    _Signals.last = _name(signum)
    raise KeyboardInterrupt


def _hold(signum: int, _frame: FrameType | None) -> None:
    _Signals.count += 1
    _Signals.last = _name(signum)
    if _Signals.pending is None:
        _Signals.pending = signum


def stopped(signame: str | None = None) -> Interrupted:
    """The exception (exit 130) for a signal that stopped the tool, naming every touched servo's state."""
    name = signame or _Signals.last
    return Interrupted(f"interrupted ({name}); {JOURNAL.state()}")


def install(bus: Any = None) -> None:
    """SIGINT, SIGTERM and SIGHUP stop the tool (``KeyboardInterrupt``) outside critical steps; with
    ``DXL_SETUP_TEST_PAUSE_AFTER=N`` in the environment (tests only) the tool pauses before the bus
    instruction after the Nth, saying so on stderr, until a signal arrives (at most 60 s)."""
    for signum in SIGNALS:
        signal.signal(signum, _stop)
    pause = os.environ.get(PAUSE_ENV, "")
    if bus is not None and pause.isdigit():
        _pause_hook(bus, int(pause))


def _pause_hook(bus: Any, after: int) -> None:
    port = bus.line
    send = port.write
    sent = [0]

    def write(packet: bytes) -> None:
        sent[0] += 1
        if sent[0] == after + 1:
            seen = _Signals.count
            print(f"[{PAUSE_ENV}] paused before instruction {after + 1}", file=sys.stderr, flush=True)
            end = time.monotonic() + 60.0
            while _Signals.count == seen and time.monotonic() < end:
                time.sleep(0.02)
        send(packet)

    port.write = write


def _swap(handlers: dict[int, Any]) -> dict[int, Any]:
    """Install ``handlers`` with the signals blocked meanwhile (one that comes goes to the new
    handler, never half way); the handlers they replace."""
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        return {signum: signal.signal(signum, handler) for signum, handler in handlers.items()}
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


@contextmanager
def held() -> Iterator[None]:
    """A critical step: SIGINT/SIGTERM/SIGHUP noted, not acted on, until it ends; then
    :class:`Interrupted` (exit 130) naming the touched servos' states. Nests (the outermost acts)."""
    if _Signals.depth == 0:
        before = _swap({s: _hold for s in SIGNALS})
    _Signals.depth += 1
    try:
        yield
    except StepFailed as exc:
        if _Signals.depth == 1 and _Signals.pending is not None:
            raise Interrupted(f"{exc}; interrupted ({_name(_Signals.pending)}) during this step; "
                              f"{JOURNAL.state()}") from None
        raise
    finally:
        _Signals.depth -= 1
        if _Signals.depth == 0:
            _swap(before)
    if _Signals.depth == 0 and _Signals.pending is not None:
        came, _Signals.pending = _Signals.pending, None
        raise Interrupted(f"interrupted ({_name(came)}) during a step that was then finished; {JOURNAL.state()}")


def needs_torque_off(item: Item, model: Model | None = None) -> bool:
    """Items a servo takes only with torque off: its EEPROM area, or those its model's protocol
    names (``ToolProtocol.torque_off_items``: a Protocol 1.0 model takes EEPROM writes with torque
    on, but its Angle Limits switch its mode and are written with torque off like an Operating Mode)."""
    if model is None:
        return item.eeprom
    return tool_protocol(model.protocol).needs_torque_off(item)


def refuse_torque(servo: _Servo, item: Item) -> TorqueOn:
    rule = tool_protocol(servo.model.protocol).torque_rule.format(item=item.name)
    return TorqueOn(f"{servo.who}: torque is on and {rule}: refused, nothing written (give --torque-off to turn it "
                    "off, write, set the goal to where it is and turn it back on)")


def checked_write(servo: S, name: str, raw: int, torque_off: bool = False,
                  after: Callable[[], S] | None = None) -> bool:
    """Write ``raw`` to item ``name`` when it differs (True if written), as one critical step.

    An EEPROM item on a servo with torque on: :class:`TorqueOn` unless ``torque_off``; with it,
    torque off, write, read back, goal := present, torque back on. ``after``: the servo to read back
    on once written (a new ID or rate: finding it there is part of the step). A failure says which
    state the servo is left in; the journal keeps it for an interrupt's report."""
    item = servo.item(name)
    before = servo.read(item.name)
    if before == raw:
        return False
    torque = needs_torque_off(item, servo.model) and servo.torque_on()
    if torque and not torque_off:
        raise refuse_torque(servo, item)
    entry = JOURNAL.touch(servo.dxl_id, servo.model.name, servo.bus.baudrate,
                          "on" if torque else ("off" if needs_torque_off(item, servo.model) else "as it was"))
    what = f"{item.name} {show_value(servo.model, item, before)} -> {show_value(servo.model, item, raw)}"
    with held():
        _step(servo, item, raw, torque, entry, what, after)
    return True


def _step(servo: S, item: Item, raw: int, torque: bool, entry: Touched, what: str,
          after: Callable[[], S] | None) -> None:
    if torque:
        servo.write("torque_enable", 0)
        entry.torque = "off (it was on; the load is not held)"
    try:
        servo.write(item.name, raw)
    except StepFailed as exc:
        if torque:
            _torque_back(servo, entry)
        raise StepFailed(f"{exc}; nothing was changed{' (torque back on)' if torque else ''}") from None
    entry.done.append(f"{what} sent")
    try:
        target = after() if after is not None else servo
        got = target.read(item.name)
    except StepFailed as exc:
        entry.done[-1] = f"{what} sent, not read back"
        raise StepFailed(f"{exc}{' (torque left off)' if torque else ''}; {JOURNAL.state()}") from None
    entry.dxl_id, entry.baudrate = target.dxl_id, target.bus.baudrate
    if torque:
        _torque_back(target, entry)
    if got != raw:
        entry.done[-1] = f"{what} sent, reads {got}"
        raise StepFailed(f"{target.who}: {item.name} reads {show_value(target.model, item, got)} after writing "
                         f"{show_value(target.model, item, raw)}")
    entry.done[-1] = f"{what} written and read back" + (", torque off and on again (goal := present)" if torque else "")


def _torque_back(servo: _Servo, entry: Touched) -> None:
    try:
        servo.torque_on_in_place()
    except StepFailed as exc:
        entry.torque = "off (it was on: turning it back on failed)"
        raise StepFailed(f"{exc}; {JOURNAL.state()}") from None
    entry.torque = "on (as before)"
