"""calibrate: each joint's range and zero pose taken by hand, written as the handler's ``joints``
block (:mod:`.joints_file`).

The named servos' torque goes off (a servo holding its load only with ``--torque-off``, asked
about without ``--yes``), a live table shows each servo's present angle and the lowest and highest
seen while the owner moves each joint through its range; Enter ends the recording; then the owner
holds the robot at its zero pose and presses Enter again. The file gets each joint's offset (the
joint reads 0 there) and its position limits, the margin inside the range moved through. With
``--homing-offset`` each servo's Homing Offset (EEPROM) is written instead, shown and asked about
first, so that the servo itself reads 0 at the zero pose (the file's offsets are then 0).

Torque is left off at the end (the handler turns it on when it starts). A failure or a signal
after torque went off names each servo's state (the journal of :mod:`.safety`) and says the file
was not written; the file is written last, whole or not at all.
"""
from __future__ import annotations

import argparse
import contextlib
import math
import queue
import threading
from dataclasses import dataclass
from typing import Callable, Iterator, TextIO, cast

from rich.live import Live
from rich.table import Table

from ..units import conversion
from . import guard
from .context import Context
from .errors import BadArguments, StepFailed
from .find import Found, Placed
from .items import show_value, to_unit
from .joints_file import Calibrated, check_parsed, check_target, joints_yaml, write_atomically
from .output import rich_table
from .per_protocol import tool_protocol
from .safety import JOURNAL, Interrupted, TorqueOn, held, stopped
from .servo import Servo
from .values import number, servo_doc

__all__ = ["calibrate"]

COLUMNS = ["ID", "joint", "model", "position", "min", "max", "range"]


class _Lines:
    """stdin's lines, read in a thread so that the table refreshes while Enter is awaited; also
    what the confirmations read (one reader of stdin for the whole verb)."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._queue: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, name="calibrate-stdin", daemon=True).start()

    def _read(self) -> None:
        while True:
            try:
                line = self._stream.readline()
            except (OSError, ValueError):
                line = ""
            self._queue.put(line)
            if not line:
                return

    def within(self, seconds: float) -> str | None:
        """The next line ("" at the end of input), None when none came within ``seconds``."""
        try:
            line = self._queue.get(timeout=max(0.0, seconds))
        except queue.Empty:
            return None
        if not line:
            self._queue.put(line)  # the end of input stays the end
        return line

    def readline(self) -> str:
        line = self._queue.get()
        if not line:
            self._queue.put(line)
        return line


@dataclass
class _Joint:
    """One servo being calibrated: where it is, its joint's name, the angles seen [deg]."""

    placed: Placed
    name: str
    low: float = math.inf
    high: float = -math.inf
    now: float | None = None
    raw: int | None = None

    @property
    def servo(self) -> Servo:
        return self.placed.servo

    def row(self) -> list[object]:
        seen = self.high >= self.low

        def deg(value: float | None) -> str:
            return f"{number(value, 4 if abs(value) >= 1 else 2)} deg" if value is not None else "no reply"
        return [self.placed.dxl_id, self.name, self.servo.model.name, deg(self.now),
                deg(self.low) if seen else "-", deg(self.high) if seen else "-",
                deg(self.high - self.low) if seen else "-"]


def _angle(servo: Servo, raw: int) -> float:
    value = to_unit(servo.model, servo.item("present_position"), raw)
    return float(value) if value is not None else math.nan


def _sample(ctx: Context, joints: list[_Joint], record: bool) -> None:
    """Each servo's present position read (at its rate); while ``record``, the lowest and highest kept."""
    for joint in joints:
        try:
            joint.raw = ctx.at(joint.placed).read("present_position")
        except StepFailed:
            joint.now = joint.raw = None
            continue
        joint.now = _angle(joint.servo, joint.raw)
        if record:
            joint.low, joint.high = min(joint.low, joint.now), max(joint.high, joint.now)


@contextlib.contextmanager
def _no_echo(stream: TextIO) -> Iterator[None]:
    """A terminal's echo off while the live table runs (Enter would scroll it); lines as typed."""
    import termios

    fd = stream.fileno()
    saved = termios.tcgetattr(fd)
    quiet = list(saved)
    quiet[3] &= ~termios.ECHO
    termios.tcsetattr(fd, termios.TCSADRAIN, quiet)
    try:
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


RECORD = "move each joint through its whole range by hand, then press Enter"
ZERO = "hold the robot at its zero pose, press Enter"


class _Session:
    """One calibration: the servos, the reader of stdin and what was done (for the failure lines)."""

    def __init__(self, ctx: Context, args: argparse.Namespace, joints: list[_Joint]) -> None:
        self.ctx, self.args, self.joints = ctx, args, joints
        self.stdin = ctx.stdin
        out = ctx.out
        self.live = out.human and out.console is not None and out.svg is None and self.stdin.isatty()
        self.lines = _Lines(self.stdin)
        ctx.stdin = cast(TextIO, self.lines)  # ctx.confirm reads through the same reader
        self.period = 1.0 / max(0.2, min(args.rate, 50.0))
        #: the torque went off (from here on a failure names each servo's state) / the file was written
        self.touched = self.written = False

    @property
    def ids(self) -> str:
        return ", ".join(str(j.placed.dxl_id) for j in self.joints)

    def failed(self, exc: StepFailed) -> StepFailed:
        """``exc`` with what the run leaves: the file not written, the torque left off."""
        if not self.touched:
            return exc
        file = f"{self.args.joints} {'written' if self.written else 'not written'}"
        if isinstance(exc, Interrupted):  # its line names each servo's state already
            return Interrupted(f"{exc}; {file}")
        if any(entry.done for entry in JOURNAL.servos):  # a Homing Offset was written: each servo's state
            return type(exc)(f"{exc}; {file}; {JOURNAL.state()}")
        off = [str(e.dxl_id) for e in JOURNAL.servos if e.torque.startswith("off")]
        on = [str(e.dxl_id) for e in JOURNAL.servos if not e.torque.startswith("off")]
        return type(exc)(f"{exc}; {file}; torque left off on ID {', '.join(off)}"
                         + (f" (still on on ID {', '.join(on)})" if on else ""))

    # ------------------------------------------------------------------ the steps
    def torque_off(self, holding: set[int]) -> None:
        """Every servo's torque off (one critical step); each one in the journal, so that a
        failure or a signal from here on names its state."""
        with held():
            for joint in self.joints:
                servo = self.ctx.at(joint.placed)
                was_on = servo.dxl_id in holding
                entry = JOURNAL.touch(servo.dxl_id, servo.model.name, joint.placed.baudrate, "on" if was_on else "off")
                self.touched = True
                if was_on:
                    servo.write("torque_enable", 0)
                    entry.torque = "off (it was on: the load is not held)"
        held_load = sorted(holding)
        self.ctx.out.say(f"torque off on ID {self.ids}" + (f" (ID {', '.join(map(str, held_load))} held a load: no "
                                                          "longer)" if held_load else ""))

    def enter(self, prompt: str, record: bool) -> None:
        """Wait for Enter (a line on stdin) while the table refreshes (``record``: the lowest and
        highest angles kept); StepFailed at the end of the input."""
        _sample(self.ctx, self.joints, record)
        if self.live:
            self.ctx.out.say(prompt)
            title = (RECORD if record else ZERO) + " (Ctrl-C: stop, nothing written)"
            with _no_echo(self.stdin), Live(self._table(title), console=self.ctx.out.console,
                                            auto_refresh=False) as view:
                line = self._wait(record, lambda: view.update(self._table(title), refresh=True))
        else:  # piped: the table as the recording starts and as it ends, no refreshes
            if record:
                self._print()
            self.ctx.out.say(prompt)
            line = self._wait(record, lambda: None)
            if record:
                self._print()
        if not line:
            raise StepFailed("the input ended before Enter (stdin closed)")

    def _wait(self, record: bool, show: Callable[[], None]) -> str:
        while True:
            line = self.lines.within(self.period)
            if line is not None:
                return line
            _sample(self.ctx, self.joints, record)
            show()

    def _table(self, title: str) -> Table:
        return rich_table(title, COLUMNS, [j.row() for j in self.joints])

    def _print(self) -> None:
        """The table as plain columns when piped (no escape codes), nothing with --json."""
        self.ctx.out.table("", COLUMNS, [j.row() for j in self.joints])

    def check_ranges(self) -> None:
        """Each joint was moved through more than twice the margin (else no limits lie inside)."""
        margin = self.args.margin_deg
        for j in self.joints:
            if not j.high >= j.low:
                raise StepFailed(f"{j.name} (ID {j.placed.dxl_id}): no position was read while recording")
            if j.high - j.low <= 2 * margin:
                raise StepFailed(f"{j.name} (ID {j.placed.dxl_id}): moved through {number(j.high - j.low)} deg "
                                 f"({number(j.low)} .. {number(j.high)} deg), not more than twice the margin (2 x "
                                 f"{number(margin)} deg): no limits fit inside; move it through its whole range, or "
                                 "give a smaller --margin-deg")

    def zero(self) -> list[Calibrated]:
        """Each servo's angle now (the zero pose) with the range recorded."""
        _sample(self.ctx, self.joints, record=False)
        out = []
        for j in self.joints:
            if j.now is None:
                raise StepFailed(f"{j.servo.who}: reading present_position at the zero pose failed (no reply)")
            out.append(Calibrated(j.name, j.placed.dxl_id, j.low, j.high, j.now, self.args.margin_deg))
            lo, hi = out[-1].limits_deg
            if not lo <= 0.0 <= hi:
                self.ctx.out.warn(f"{j.name} (ID {j.placed.dxl_id}): the zero pose lies outside its limits "
                                  f"({number(lo)} .. {number(hi)} deg from it): a command to 0 is held to them")
        return out

    def home(self, results: list[Calibrated]) -> list[dict[str, int]]:
        """``--homing-offset``: each servo's Homing Offset so that it reads 0 at the zero pose,
        shown (old and new) and asked about (``--yes`` skips it), then written and read back."""
        plan = []
        for joint in self.joints:
            servo = self.ctx.at(joint.placed)
            old = servo.read("homing_offset")
            centre = float(conversion([servo.model], "present_position")[0][0])  # the raw value of 0 deg
            new = old + int(round(centre - (joint.raw or 0)))
            guard.check_values(self.ctx, servo, {"homing_offset": new})
            plan.append((joint, old, new))
        item = self.joints[0].servo.item("homing_offset")
        rows = [[j.placed.dxl_id, j.name, show_value(j.servo.model, item, old), show_value(j.servo.model, item, new)]
                for j, old, new in plan]
        self.ctx.out.table("Homing Offset (EEPROM)", ["ID", "joint", "now", "new"], rows)
        for row in rows if self.ctx.out.as_json else []:  # on stderr, before the question
            self.ctx.out.say(f"ID {row[0]} ({row[1]}) homing_offset now {row[2]}, new {row[3]}")
        self.ctx.confirm(f"write the Homing Offset of ID {self.ids} (EEPROM; torque is off)? Each then reads 0 deg at "
                         "this pose")
        done = []
        for (joint, old, new), result in zip(plan, results):
            servo = self.ctx.at(joint.placed)
            written = servo.set_checked("homing_offset", new)
            result.homed = True
            now = _angle(servo, servo.read("present_position"))
            self.ctx.out.say(f"{servo.who} homing_offset = {show_value(servo.model, item, new)} "
                             + (f"(was {show_value(servo.model, item, old)}), read back" if written else "(as it was)")
                             + f"; it reads {number(now, 3)} deg at the zero pose")
            done.append({"id": servo.dxl_id, "was": old, "now": new})
        return done

    def write(self, results: list[Calibrated]) -> None:
        """The file, checked with the node's parser, written whole or not at all."""
        text = joints_yaml(results, self.ctx.bus.device)
        check_parsed(text, results)
        with held():
            write_atomically(self.args.joints, text, replace=self.ctx.force)
            self.written = True

    def report(self, results: list[Calibrated], homing: list[dict[str, int]]) -> None:
        rows = []
        docs = []
        for j, r in zip(self.joints, results):
            lo, hi = r.limits_deg
            rows.append([j.placed.dxl_id, r.name, f"{number(r.zero_deg)} deg",
                         f"{number(r.low_deg - r.zero_deg)} .. {number(r.high_deg - r.zero_deg)} deg",
                         f"{number(lo)} .. {number(hi)} deg", f"{r.offset_rad:.4f} rad"])
            docs.append(servo_doc(j.placed.dxl_id, j.servo.model, j.placed.baudrate, joint=r.name, zero_deg=r.zero_deg,
                                  min_deg=r.low_deg, max_deg=r.high_deg, offset_rad=r.offset_rad,
                                  limits_rad=list(r.limits_rad), torque=False))
        self.ctx.out.table("", ["ID", "joint", "zero pose", "moved (from zero)", "limits (from zero)", "offset"], rows)
        self.ctx.out.say(f"the joints block of {', '.join(r.name for r in results)} written to {self.args.joints} "
                         f"(a parameters file: --params-file {self.args.joints})")
        self.ctx.out.say(f"torque left off on ID {self.ids}: the joints do not hold; the handler turns it on when it "
                         "starts")
        self.ctx.out.document.update(file=self.args.joints, servos=docs, homing_offset=homing,
                                     margin_deg=self.args.margin_deg)

    def run(self, holding: set[int]) -> None:
        self.torque_off(holding)
        self.enter(RECORD, record=True)
        self.check_ranges()
        self.enter(ZERO, record=False)
        results = self.zero()
        homing = self.home(results) if self.args.homing_offset else []
        self.write(results)
        self.report(results, homing)


# ---------------------------------------------------------------------------- before anything is done
def _servos(ctx: Context, args: argparse.Namespace) -> Found:
    """The servos named (every one on the bus without IDs); one missing refuses the calibration."""
    if args.ids is None:
        return ctx.search.every()
    found = ctx.search.find(args.ids)
    if found.missing:
        raise StepFailed("; ".join(found.why_missing(i) for i in found.missing) + ": refused, nothing done (name "
                         "only servos that answer)")
    for placed in found.placed:
        guard.only_one(ctx, ctx.at(placed))
    return found


def _joints(found: Found, args: argparse.Namespace) -> list[_Joint]:
    """The joints in the order of the IDs given (ascending without them), named as ``--names`` says."""
    order = args.ids or [p.dxl_id for p in found.placed]
    placed = {p.dxl_id: p for p in found.placed}
    if args.names is not None and len(args.names) != len(order):
        raise BadArguments(f"--names gives {len(args.names)} name(s) for {len(order)} servo(s) (ID "
                           f"{', '.join(map(str, order))}): one per servo, in the order of the IDs")
    names = args.names or [f"joint_{i}" for i in order]
    return [_Joint(placed[i], n) for i, n in zip(order, names)]


def _check_models(joints: list[_Joint], homing: bool) -> None:
    for joint in joints:
        servo = joint.servo
        if not servo.model.has("present_position"):
            raise BadArguments(f"{servo.who}: the model reports no position: it cannot be calibrated")
        refused = tool_protocol(servo.protocol).homing_refused
        if homing and (refused or not servo.model.has("homing_offset")):
            why = refused or "the model has no Homing Offset"
            raise BadArguments(f"{servo.who}: {why}: --homing-offset refused, nothing done (without it the offsets go "
                               "in the file)")


def _holding(ctx: Context, joints: list[_Joint]) -> set[int]:
    """The IDs whose torque is on: refused (TorqueOn, nothing done) without --torque-off, asked
    about without --yes."""
    holding = {j.placed.dxl_id for j in joints if ctx.at(j.placed).torque_on()}
    if not holding:
        return holding
    ids = ", ".join(map(str, sorted(holding)))
    if not ctx.torque_off:
        raise TorqueOn(f"ID {ids}: torque is on and calibrate turns it off (the joints are moved by hand), which lets "
                       "go of the load it holds: refused, nothing done (support the robot and give --torque-off)")
    ctx.confirm(f"torque goes off on ID {', '.join(str(j.placed.dxl_id) for j in joints)} and stays off; ID {ids} "
                f"{'holds' if len(holding) == 1 else 'hold'} a load now: support the robot. Go on?")
    return holding


def calibrate(ctx: Context, args: argparse.Namespace) -> None:
    check_target(args.joints, ctx.force)
    joints = _joints(_servos(ctx, args), args)
    _check_models(joints, args.homing_offset)
    session = _Session(ctx, args, joints)
    ctx.out.say(f"calibrate {', '.join(f'{j.name} (ID {j.placed.dxl_id})' for j in joints)} -> {args.joints}")
    try:
        session.run(_holding(ctx, joints))
    except KeyboardInterrupt:  # a signal between critical steps
        raise session.failed(stopped()) from None
    except StepFailed as exc:
        raise session.failed(exc) from None
