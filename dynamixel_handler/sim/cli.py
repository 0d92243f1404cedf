"""``dynamixel_handler_sim``: serve a virtual Dynamixel bus on a pseudo-terminal.

The first line printed on stdout is the device path to open (flushed at once), so a script
can do ``DEV=$(dynamixel_handler_sim | head -1)``-style plumbing or read one line from a pipe.
Faults can be changed while it runs by typing commands on stdin (``help`` lists them).

By default the servos behave like unboxed hardware: factory values, 57600 bps, answering only a
host whose port is at their own baud rate, with the wire's time simulated. Every flag is in
``--help`` and in docs/virtual_bus.md.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
from typing import Callable

from dynamixel_handler.control_table import known_models, model_by_number
from dynamixel_handler.signal_flag import SignalFlag

from . import DEFAULT_SERVOS
from .bus import AnyServo, VirtualBus
from .protocol1 import PROTOCOL1_MODELS, protocol1_model

SAVE_PERIOD_S = 0.5
#: what ``list`` adds to a servo that answers another protocol than 2.0
_PROTOCOL_MARKS = {1: " [Protocol 1.0]"}

COMMANDS_HELP = """commands (one per line on stdin):
  silent ID | answer ID        an ID stops answering / comes back
  crc RATE                     probability of a corrupted reply CRC (0..1)
  garbage N                    N noise bytes before the next reply
  truncate [N]                 cut the next N replies short
  hwerr ID BITS                set hardware error bits (torque drops per shutdown mask)
  vanish | reappear            unplug / replug the adapter
  add ID MODEL [--again]       plug in a servo (factory values, this ID); --again: also when a
                               servo already answers at that ID (both collide on the wire)
  remove ID                    unplug the servo(s) at ID
  turn ID DEG                  turn a shaft by hand until it reads DEG (0 at its middle; torque off)
  list | help | quit"""


def parse_model(text: str) -> int:
    """A model number or a model name such as XM430-W350 or AX-12A (case-insensitive).

    A Protocol 2.0 model wins a name both firmwares have: "MX-28" is the MX-28(2.0) (model 30), as
    are "MX-64" and "MX-106"; "MX-28(1.0)" or 29 is the Protocol 1.0 one. Every Protocol 1.0 model
    goes by its name (AX-12A, AX-12W, AX-18A, RX-10, RX-24F, RX-28, RX-64, DX-113, DX-116, DX-117,
    EX-106+, MX-12W, MX-28(1.0), MX-64(1.0), MX-106(1.0)) or number. "YM080-230-A099" names
    YM080-230-A099-RH (the SDK's spelling of the Y names)."""
    text = text.strip()
    if text.isdigit() and protocol1_model(text) is None:
        number = int(text)
        model_by_number(number)
        return number
    for model in known_models():
        if model.name.lower() == text.lower():
            return model.number
    old = protocol1_model(text) if text.lower().endswith("(1.0)") or text.isdigit() else None
    if old is not None:
        return old.number
    for model in known_models():
        if model.name.lower().replace("(2.0)", "").removesuffix("-rh") == text.lower():
            return model.number
    old = protocol1_model(text)
    if old is not None:
        return old.number
    raise argparse.ArgumentTypeError(f"unknown model {text!r} (see --list-models)")


def _servo_arg(text: str) -> tuple[int, int]:
    try:
        sid, model = text.split(":", 1)
        return int(sid), parse_model(model)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ID:MODEL, got {text!r}") from None


def _id_list(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        if "-" in part:
            lo, hi = part.split("-", 1)
            out += list(range(int(lo), int(hi) + 1))
        elif part.strip():
            out.append(int(part))
    return out


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="dynamixel_handler_sim",
        description="Serve virtual Dynamixel servos (Protocol 2.0 and 1.0) on a pseudo-terminal. "
                    "Prints the device path as the first line of stdout, then serves until "
                    "SIGINT/SIGTERM. Default bus: 1 XM430-W350, 2 XM540-W270, "
                    "3 PH54-200-S500-R, 4 H54-200-S500-R.",
        epilog=COMMANDS_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--servo", action="append", type=_servo_arg, metavar="ID:MODEL", default=[],
                    help="add a servo (model number or name), repeatable")
    ap.add_argument("--ids", type=_id_list, metavar="LIST", help="IDs, e.g. 1,2,5-8 (with --models)")
    ap.add_argument("--models", metavar="LIST",
                    help="models for --ids, comma separated; one model applies to all IDs")
    ap.add_argument("--link", metavar="PATH", help="also expose the device as this symlink, e.g. /tmp/ttyDXL")
    ap.add_argument("--baudrate", type=int, metavar="BPS",
                    help="put every servo at this baud rate (its Baud Rate register; default: the "
                         "factory value, 57600 bps) and time the wire at it")
    ap.add_argument("--no-wire-timing", action="store_true",
                    help="reply as fast as possible instead of taking the wire time of each "
                         "packet and the servos' Return Delay Time (default: timed, as on hardware)")
    ap.add_argument("--any-baudrate", action="store_true",
                    help="servos answer a host at any baud rate (default: only at their own Baud "
                         "Rate register, as on hardware)")
    ap.add_argument("--check-baudrate", action="store_true",
                    help="servos answer only at their own baud rate (the default; kept for scripts)")
    ap.add_argument("--state", metavar="FILE",
                    help="load the servos' EEPROM (ID, baud rate, limits, ...) from FILE if it exists "
                         "and save it there whenever it changes, so it survives a restart")
    ap.add_argument("--latency-ms", type=float, default=0.0, help="extra latency per transaction (ms)")
    ap.add_argument("--silent", type=_id_list, default=[], metavar="LIST", help="IDs that do not answer")
    ap.add_argument("--crc-error-rate", type=float, default=0.0, metavar="P",
                    help="probability that a reply has a bad CRC")
    ap.add_argument("--hardware-error", action="append", default=[], metavar="ID:BITS",
                    help="start with hardware error bits set on a servo")
    ap.add_argument("--seed", type=int, help="random seed for fault injection")
    ap.add_argument("--list-models", action="store_true", help="print the supported models and exit")
    ap.add_argument("--quiet", action="store_true", help="print only the device path")
    return ap


def _ids_models(args: argparse.Namespace, ap: argparse.ArgumentParser) -> dict[int, int]:
    """{ID: model} of ``--ids`` and ``--models``."""
    if not args.ids:
        if args.models:
            ap.error("--models needs --ids")
        return {}
    models = [parse_model(m) for m in (args.models or "XM430-W350").split(",")]
    if len(models) == 1:
        models *= len(args.ids)
    if len(models) != len(args.ids):
        ap.error("--models needs one model or one per ID")
    return dict(zip(args.ids, models))


def _servos_from(args: argparse.Namespace, ap: argparse.ArgumentParser) -> list[tuple[int, int]]:
    """(ID, model) per servo: ``--servo`` replaces an ``--ids`` entry of its ID, and a ``--servo``
    ID given twice puts two servos at it (they collide)."""
    servos = _ids_models(args, ap)
    given = {sid for sid, _ in args.servo}
    pairs = [(sid, model) for sid, model in servos.items() if sid not in given] + list(args.servo)
    for sid, _ in pairs:
        if not 0 <= sid <= 252:
            ap.error(f"ID {sid} out of range 0..252")
    return pairs or list(DEFAULT_SERVOS.items())


def describe_servo(bus: VirtualBus, servo: AnyServo) -> str:
    """One line per servo: ID, model, baud rate, protocol, and whether it collides or is silent."""
    marks = _PROTOCOL_MARKS.get(servo.protocol, "")
    if len(_colliding(bus, servo)) > 1:
        marks += " [shares its ID: collides]"
    marks += " [silent]" if servo.silent else ""
    return f"ID {servo.id}: {servo.model.name} ({servo.model.number}) at {servo.baudrate} bps{marks}"


def _colliding(bus: VirtualBus, servo: AnyServo) -> list[AnyServo]:
    """The servos that answer together with ``servo``: same ID, protocol and baud rate."""
    return [s for s in bus.servos_at(servo.id)
            if s.protocol == servo.protocol and s.baudrate == servo.baudrate]


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text!r} is not a finite angle")
    return value


def _list(bus: VirtualBus, rest: list[str]) -> str:
    return "\n".join(describe_servo(bus, s) for s in bus.all_servos)


def _add(bus: VirtualBus, rest: list[str]) -> str | None:
    """``add ID MODEL [--again]``: refused when a servo already answers at that ID (same protocol
    and baud rate as the new one) unless ``--again`` asks for the collision."""
    again = "--again" in rest
    words = [w for w in rest if w != "--again"]
    servo_id, model = int(words[0]), parse_model(words[1])
    if not 0 <= servo_id <= 252:
        raise ValueError(f"ID {servo_id} out of range 0..252")
    with bus.lock:
        servo = bus.add_servo(servo_id, model)
        others = [s for s in _colliding(bus, servo) if s is not servo]
        if others and not again:
            bus.unplug(servo)
            raise ValueError(f"ID {servo_id} already answers ({others[0].model.name} at "
                             f"{others[0].baudrate} bps); 'add {servo_id} {words[1]} --again' puts a "
                             "second servo at it (their replies collide)")
    return f"ok; ID {servo_id} now has {len(others) + 1} servos: their replies collide" if others else None


# Run-time commands: name -> what it does (an answer, or None for "ok").
_COMMANDS: dict[str, Callable[[VirtualBus, list[str]], str | None]] = {
    "silent": lambda bus, rest: bus.set_silent(int(rest[0]), True),
    "answer": lambda bus, rest: bus.set_silent(int(rest[0]), False),
    "crc": lambda bus, rest: setattr(bus, "crc_error_rate", float(rest[0])),
    "garbage": lambda bus, rest: bus.inject_garbage(int(rest[0])),
    "truncate": lambda bus, rest: bus.truncate_next(int(rest[0]) if rest else 1),
    "hwerr": lambda bus, rest: bus.set_hardware_error(int(rest[0]), int(rest[1], 0)),
    "vanish": lambda bus, rest: bus.vanish(),
    "reappear": lambda bus, rest: f"device {bus.reappear()}",
    "add": _add,
    "remove": lambda bus, rest: bus.remove_servo(int(rest[0])),
    "turn": lambda bus, rest: bus.turn(int(rest[0]), _finite(rest[1])),
    "list": _list,
    "help": lambda bus, rest: COMMANDS_HELP,
}


def run_command(bus: VirtualBus, line: str) -> str:
    """Apply one run-time command; returns a short human answer."""
    words = line.split()
    if not words:
        return ""
    cmd, rest = words[0].lower(), words[1:]
    action = _COMMANDS.get(cmd)
    if action is None:
        return f"unknown command {cmd!r}; try help"
    try:
        answer = action(bus, rest)
    except (IndexError, ValueError, KeyError, argparse.ArgumentTypeError) as exc:
        return f"error: {exc}"
    return "ok" if answer is None else answer


def _bus_from(args: argparse.Namespace, ap: argparse.ArgumentParser) -> VirtualBus:
    """The bus the flags describe, faults set, not started yet (a bad flag ends the program)."""
    if args.any_baudrate and args.check_baudrate:
        ap.error("--any-baudrate and --check-baudrate contradict each other")
    servos = _servos_from(args, ap)
    try:
        bus = VirtualBus(servos, baudrate=args.baudrate, latency_s=args.latency_ms / 1000.0,
                         link=args.link, seed=args.seed, check_baudrate=not args.any_baudrate,
                         wire_timing=not args.no_wire_timing, state_file=args.state)
    except (ValueError, OSError, KeyError) as exc:  # a model that cannot run at --baudrate, a bad state file
        ap.error(str(exc))
    bus.crc_error_rate = args.crc_error_rate
    for sid in args.silent:
        bus.set_silent(sid)
    for spec in args.hardware_error:
        sid, bits = spec.split(":", 1)
        bus.set_hardware_error(int(sid), int(bits, 0))
    return bus


def _list_models() -> None:
    for model in known_models():
        print(f"{model.number:6d}  {model.name}  ({model.series})")
    for old in PROTOCOL1_MODELS.values():  # by the name --servo takes: MX-28(1.0), as MX-28 is the 2.0 one
        name = old.name if parse_model(old.name) == old.number else f"{old.name}(1.0)"
        print(f"{old.number:6d}  {name}  (Protocol 1.0: answers only 1.0 packets; the handler drives it with "
              f"init/used_servo_series.{old.family.title})")


def main(argv: list[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    if args.list_models:
        try:
            _list_models()
            sys.stdout.flush()  # here, not at exit: a closed pipe is answered below
        except BrokenPipeError:  # e.g. `--list-models | head`: the reader has what it wanted
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    bus = _bus_from(args, ap)
    stop = threading.Event()  # the console's "quit" sets it; a signal only sets the flag (see signal_flag)
    signalled = SignalFlag()
    signalled.install(signal.SIGINT, signal.SIGTERM)
    path = bus.start()
    print(path, flush=True)
    if not args.quiet:
        for servo in bus.all_servos:
            print(describe_servo(bus, servo), file=sys.stderr)
        print("serving; Ctrl-C to stop", file=sys.stderr, flush=True)
    threading.Thread(target=_console, args=(bus, stop, args.quiet), daemon=True).start()
    try:
        while not (signalled.wait(stop.is_set, SAVE_PERIOD_S) or stop.is_set()):
            if args.state and bus.eeprom_changed:
                bus.save_state()
    finally:
        bus.close()
        if args.state:
            bus.save_state()
    return 0


def _console(bus: VirtualBus, stop: threading.Event, quiet: bool) -> None:
    """Read run-time fault commands from stdin until EOF (EOF does not stop the bus)."""
    try:
        for line in sys.stdin:
            if line.strip().lower() in ("quit", "exit"):
                stop.set()
                return
            answer = run_command(bus, line)
            if answer and not quiet:
                print(answer, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        return
