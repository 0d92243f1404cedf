"""The command line of ``dynamixel_handler_setup``: verbs, the options every verb takes, and the
run of one verb (exit code 0 done, 1 a servo or the bus failed, 2 bad arguments, 130 interrupted;
every error one line)."""
from __future__ import annotations

import argparse
import math
import os
import re
import sys
from typing import Any, Callable, NoReturn, Sequence

from ..bus import DYNAMIXEL_BAUDRATES, DynamixelBus
from ..control_table import protocol1_models
from . import backup, calibrate, monitor, plot, restore, through_node, trace, verbs_bus, verbs_config, verbs_many
from .checks import cut
from .context import Context
from .errors import StepFailed
from .joints_file import parse_margin, parse_names
from .output import Output
from .port import default_device, open_bus
from .safety import JOURNAL, install, stopped

__all__ = ["build_parser", "main", "parse_ids", "parse_rates"]

PROG = "dynamixel_handler_setup"
Verb = Callable[[Context, argparse.Namespace], None]


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad command line in one line (exit code 2) and takes a value with a
    unit that starts with a minus (``-90deg``) as a value, as it takes ``-90``."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message: str) -> NoReturn:
        print(f"error: {cut(message, 300)} (see {self.prog} --help)", file=sys.stderr)
        sys.exit(2)


def parse_ids(text: str) -> list[int]:
    """``"1-5,8"`` -> [1, 2, 3, 4, 5, 8] (IDs 0..252)."""
    ids: set[int] = set()
    try:
        for part in text.split(","):
            lo, _, hi = part.strip().partition("-")
            first, last = int(lo), int(hi) if hi else int(lo)
            if not 0 <= first <= last <= 252:
                raise ValueError
            ids.update(range(first, last + 1))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a list of IDs 0..252 (e.g. 1-5,8)") from None
    return sorted(ids)


def ordered_ids(text: str) -> list[int]:
    """``"3,1,2"`` -> [3, 1, 2]: IDs in the order given (ranges ascending), none twice."""
    ids = [i for part in text.split(",") for i in parse_ids(part)]
    if len(set(ids)) != len(ids):
        raise argparse.ArgumentTypeError(f"'{cut(text)}' names an ID twice")
    return ids


def ids_or_all(text: str) -> list[int] | None:
    """``all`` (None: every servo found) or a list of IDs."""
    return None if text.strip().lower() == "all" else parse_ids(text)


def servo_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 252:
        raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a servo ID (0..252)")
    return value


def _positive(kind: type) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except (ValueError, OverflowError):
            value = 0
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a {'whole ' if kind is int else ''}number above 0 "
                                             "(and finite)")
        return value
    return parse


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a whole number of 0 or more")
    return value


def _at_most(parse: Callable[[str], Any], most: float, unit: str) -> Callable[[str], Any]:
    """``parse``, and refused above ``most`` (a value no adapter or bus needs)."""
    def within(text: str) -> Any:
        value = parse(text)
        if value > most:
            raise argparse.ArgumentTypeError(f"'{cut(text)}' is more than {most:g}{unit}")
        return value
    return within


def baud(text: str) -> int:
    try:
        value = int(float(text.lower().replace("m", "e6").replace("k", "e3")))
    except (ValueError, OverflowError):  # not a number; inf, 1e400
        value = -1
    if value not in DYNAMIXEL_BAUDRATES:
        raise argparse.ArgumentTypeError(f"'{cut(text)}' is not a Dynamixel baud rate "
                                         f"({', '.join(map(str, DYNAMIXEL_BAUDRATES))})")
    return value


def new_baud(text: str) -> int:
    """A rate for ``set-baud``: a Dynamixel rate the bus opens, or one of a Protocol 1.0 baud table
    (500,000 bps on an AX: refused by ``set-baud`` with why, rather than as no baud rate at all)."""
    try:
        return baud(text)
    except argparse.ArgumentTypeError:
        try:
            value = int(float(text.lower().replace("m", "e6").replace("k", "e3")))
        except (ValueError, OverflowError):
            value = -1
        if value in {bps for m in protocol1_models() for bps in m.baud_rates.values()}:
            return value
        raise


def parse_rates(text: str) -> list[int]:
    """``all`` or ``57600,1000000`` (``1M`` works too)."""
    if text.strip().lower() == "all":
        return []
    return [baud(part) for part in text.split(",")]


def _common(parser: argparse.ArgumentParser, suppress: bool) -> None:
    """The options every verb takes (before or after the verb)."""
    def default(value: object) -> object:
        return argparse.SUPPRESS if suppress else value

    g = parser.add_argument_group("options every verb takes")
    g.add_argument("--device", default=default(None), metavar="PATH",
                   help="the adapter: a tty, a /dev/serial/by-id link or serial:<USB serial> "
                        "(default: $DXL_DEVICE, else /dev/ttyUSB0)")
    g.add_argument("--baud", default=default(None), metavar="BPS",
                   help="where the servos are: one rate, a LIST (57600,1M: looked at in this order) or all (the "
                        "default: every rate; assign-ids: the one rate its servos are given)")
    g.add_argument("--yes", "-y", action="store_true", default=default(False), help="no confirmation before EEPROM writes")
    g.add_argument("--torque-off", action="store_true", default=default(False),
                   help="allow turning a servo's torque off for an EEPROM write or a reboot (it is turned back on "
                        "with the goal where the servo is); without it a servo with torque on is refused")
    g.add_argument("--force", action="store_true", default=default(False),
                   help="write values that lower a protection (Shutdown bits, a limit beyond its factory value, "
                        "a reversed direction, a Secondary ID another servo has); calibrate: replace its --joints FILE")
    g.add_argument("--raw", action="store_true", default=default(False),
                   help="set: the value is the register value, not a value in the item's unit")
    g.add_argument("--protocol", choices=("2", "1", "both"), default=default(None),
                   help="the protocols servos are looked for in: scan looks in both unless told; other verbs look for "
                        "an ID in both (2.0 first) and for every servo (no IDs, all) in 2.0 unless told (Protocol 1.0 "
                        "has no broadcast ping: each ID is pinged, about 3 s a rate)")
    g.add_argument("--json", action="store_true", default=default(False), help="one JSON document on stdout")
    g.add_argument("--latency", type=_at_most(_positive(float), 255, " ms (an adapter's latency timer: 1..255)"),
                   default=default(4.0), metavar="MS",
                   help="adapter latency timer [ms] for reply timeouts (default 4; FTDI adapters are set to it)")
    g.add_argument("--retries", type=_at_most(_count, 10, ""), default=default(2), metavar="N",
                   help="retries of a failed transaction (0..10)")
    g.add_argument("--svg", default=default(None), metavar="FILE",
                   help="also save the output as it looks in a terminal, as an SVG picture")
    g.add_argument("--trace", action="store_true", default=default(False),
                   help="print every instruction and status packet on stderr: time, hex and what it means")
    g.add_argument("--direct", action="store_true", default=default(False),
                   help="open the port even when a running handler holds it (refused then) instead of going through "
                        "the node (get, set, info, backup, monitor and set-mode go through it; the others are refused there)")


def _verbs(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    def verb(name: str, fn: Verb, text: str) -> argparse.ArgumentParser:
        p: argparse.ArgumentParser = sub.add_parser(name, help=text, description=text)
        _common(p, suppress=True)
        p.set_defaults(verb=fn, verb_name=name)
        return p

    p = verb("scan", verbs_bus.scan, "find every servo: all baud rates and IDs, Protocol 2.0 and 1.0")
    p.add_argument("--ids", type=parse_ids, default=list(range(253)), metavar="RANGE", help="IDs (default 0-252)")
    p = verb("info", verbs_config.info, "every control-table item of a servo, in units and raw")
    p.add_argument("id", type=servo_id)
    p.add_argument("--all", action="store_true", help="also the indirect address and data entries")
    p = verb("get", verbs_many.one_or_many(verbs_config.get, verbs_many.get_many),
             "read one item (of several servos: 1,2,5 or 1-4, one sync read)")
    p.add_argument("id", type=parse_ids, metavar="IDS")
    p.add_argument("item")
    p = verb("set", verbs_many.one_or_many(verbs_config.set_item, verbs_many.set_many),
             "write one item: a raw value or with a unit (170deg, 1.5rad, 300mA, 12.0V); "
             "of several servos (1,2,5 or 1-4) in one sync write")
    p.add_argument("id", type=parse_ids, metavar="IDS")
    p.add_argument("item")
    p.add_argument("value")
    p = verb("set-id", verbs_config.set_id, "give a servo another ID (refused when the new one is in use)")
    p.add_argument("old", type=servo_id)
    p.add_argument("new", type=servo_id)
    p = verb("set-baud", verbs_config.set_baud, "give a servo another baud rate and find it there")
    p.add_argument("id", type=servo_id)
    p.add_argument("bps", type=new_baud)
    p = verb("set-mode", verbs_many.one_or_many(verbs_config.set_mode, verbs_many.mode_many),
             "operating mode: current, velocity, position, ex_position, "
             "cur_position, pwm or a register value (of several servos: 1,2,5, one sync write)")
    p.add_argument("id", type=parse_ids, metavar="IDS")
    p.add_argument("mode")
    p = verb("assign-ids", verbs_bus.assign_ids, "connect new servos one at a time: each gets the next free ID "
             "and the bus's baud rate")
    p.add_argument("start", type=servo_id)
    p.add_argument("--ids", type=parse_ids, default=list(range(253)), metavar="RANGE",
                   help="IDs new servos may have (default 0-252)")
    p.add_argument("--search-baud", type=parse_rates, default=[], metavar="LIST",
                   help="rates new servos may be at (default all)")
    p = verb("reboot", verbs_bus.reboot, "reboot servos: an ID, a list (1,2,5 or 1-4) or all")
    p.add_argument("id", type=ids_or_all, metavar="IDS|all")
    p = verb("factory-reset", verbs_bus.factory_reset, "reset a servo to its factory values")
    p.add_argument("id", type=servo_id)
    keep = p.add_mutually_exclusive_group(required=True)
    keep.add_argument("--keep", choices=("id", "id,baud"), help="keep the ID (and the baud rate)")
    keep.add_argument("--all", action="store_true", help="reset everything: the servo comes back as ID 1 at 57600 bps")
    p = verb("backup", backup.backup, "save servos' EEPROM items and model to a YAML file")
    p.add_argument("file")
    p.add_argument("--servos-block", metavar="FILE",
                   help="also write mode, gains, limits and profiles as the handler's servos block (a parameters file)")
    p.add_argument("ids", nargs="?", type=parse_ids, help="IDs (default: every servo found, at any rate unless --baud)")
    p = verb("restore", restore.restore, "write a backup back: model checked, only what differs, verified")
    p.add_argument("file")
    p.add_argument("--dry-run", action="store_true",
                   help="show what would change, write nothing; exit 1 when a servo could not be restored")
    p = verb("monitor", monitor.monitor, "a live table of the servos (q quits)")
    p.add_argument("ids", nargs="?", type=parse_ids, help="IDs (default: every servo found, at any rate unless --baud)")
    p.add_argument("--rate", type=_positive(float), default=5.0, metavar="HZ", help="refreshes a second (default 5)")
    p.add_argument("--count", type=_positive(int), metavar="N", help="print N refreshes as plain text and stop")
    p.add_argument("--once", action="store_const", const=1, dest="count", help="one refresh (--count 1)")
    p.add_argument("--log", metavar="FILE.csv", help="also write every refresh to a CSV file (a timestamped row per servo)")
    p.add_argument("--plot", nargs="+", metavar="FILE.svg [ITEMS]",
                   help="at the end draw ITEMS (default position,velocity,current; also pwm, temperature, voltage) "
                        "over time, goal dashed against present, as an SVG")
    p = verb("calibrate", calibrate.calibrate, "each joint's range and zero pose by hand (torque off, a live table): "
             "the joints block (offsets, position limits) written to a parameters file")
    p.add_argument("ids", nargs="?", type=ordered_ids, metavar="IDS", help="IDs (default: every servo found)")
    p.add_argument("--joints", required=True, metavar="FILE",
                   help="the parameters file to write (an existing one only with --force)")
    p.add_argument("--names", type=parse_names, metavar="A,B,C", help="joint names in the order of IDS (default joint_<ID>)")
    p.add_argument("--margin-deg", type=parse_margin, default=5.0, metavar="DEG",
                   help="the limits lie this far inside the range moved through (default 5)")
    p.add_argument("--homing-offset", action="store_true",
                   help="write each servo's Homing Offset (EEPROM, shown and asked) so that it reads 0 at the zero pose; "
                        "the file's offsets are then 0")
    p.add_argument("--rate", type=_positive(float), default=5.0, metavar="HZ", help="table refreshes a second (default 5)")
    p = verb("plot", _no_bus, "draw a monitor --log CSV as an SVG: items over time, goal dashed against present")
    p.add_argument("csv", metavar="FILE.csv")
    p.add_argument("svg_file", metavar="FILE.svg")
    p.add_argument("items", nargs="?", help="position,velocity,current (default), pwm, temperature, voltage")


def _no_bus(ctx: Context, args: argparse.Namespace) -> None:
    """The verbs that need no bus (``plot``) run in ``main`` before it is opened."""


def _open(args: argparse.Namespace, rate: int) -> DynamixelBus:
    """The bus for the verb (``--trace``: every packet on it printed on stderr)."""
    bus = open_bus(args.device or default_device(), rate, args.latency, args.retries)
    if args.trace:
        trace.install(bus, sys.stderr)
    return bus


def _through_node(out: Output, args: argparse.Namespace) -> bool:
    """The verb done through (or refused by) the running handler that holds the port; False when
    none holds it or ``--direct`` was given."""
    device = args.device or default_device()
    owner = None if args.direct else through_node.owner_of(device)
    if owner is None:
        return False
    through_node.run(owner, device, out, args)
    return True


def _plot(out: Output, args: argparse.Namespace) -> None:
    out.document.update(plot.plot(args))
    out.say(f"plot of {', '.join(out.document['items'])} saved to {args.svg_file}")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description="Set up Dynamixel servos from a terminal: find them, give them IDs, "
                     "baud rates, modes and limits, back them up, watch them, calibrate the joints by hand. On a port a "
                     "running handler holds, get, set, info, backup, monitor and set-mode go through the node; the "
                     "other verbs need it stopped.",
                     epilog="exit codes: 0 done, 1 a servo or the bus failed, 2 bad arguments (nothing sent), "
                     "130 interrupted (Ctrl-C, SIGTERM, SIGHUP: after the step in progress, the state of each servo "
                     "written to is named)")
    _common(parser, suppress=False)
    sub = parser.add_subparsers(title="verbs", metavar="VERB", required=True, parser_class=_Parser)
    _verbs(sub)
    return parser


def _bus_rate(args: argparse.Namespace) -> tuple[int, bool]:
    """The rate to open the bus at and whether one rate was given; scan keeps its list, and the
    other verbs look for their servos at the rates of a list (``args.rates``)."""
    args.rates = []
    if args.baud is None:
        return 57600, False
    if args.verb_name == "scan":
        args.rates = parse_rates(args.baud)
        return (args.rates or [57600])[0], True
    if args.verb_name != "assign-ids" and ("," in args.baud or args.baud.strip().lower() == "all"):
        args.rates = parse_rates(args.baud)
        return (args.rates or [57600])[0], False
    return baud(args.baud), True


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    install()  # SIGTERM and SIGHUP stop the tool as Ctrl-C does, with exit code 130 (verbs without a bus too)
    out = Output(as_json=args.json, svg=args.svg)
    try:
        rate, given = _bus_rate(args)
    except argparse.ArgumentTypeError as exc:
        parser.error(f"argument --baud: {exc}")
    bus = None
    code = 0
    try:
        if args.verb is _no_bus:
            _plot(out, args)
        elif not _through_node(out, args):
            bus = _open(args, rate)
            args.verb(Context(bus, out, given, args.yes, torque_off=args.torque_off, force=args.force, raw=args.raw,
                              protocols=args.protocol, rates=args.rates), args)
    except StepFailed as exc:
        out.error(str(exc))
        out.document["error"] = str(exc)
        code = exc.exit_code
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = 1
    except KeyboardInterrupt:  # a signal outside a critical step: nothing was half done
        stop = stopped()
        out.error(str(stop))
        out.document["error"] = str(stop)
        code = stop.exit_code
    except Exception as exc:  # a defect: still one line (and the exit code of a failed step)
        out.error(f"unexpected {type(exc).__name__}: {exc} (a defect of {PROG}: please report it)")
        out.document["error"] = f"{type(exc).__name__}: {exc}"
        code = 1
    finally:
        if bus is not None:
            bus.close()
    return _finish(out, args, code)


def _finish(out: Output, args: argparse.Namespace, code: int) -> int:
    """The JSON document (and --svg picture) written; the exit code (1 when they cannot be)."""
    out.document["ok"] = code == 0
    if code and JOURNAL.servos:  # what a failed or interrupted run left each servo it wrote to as
        out.document["touched"] = JOURNAL.as_list()
    try:
        out.finish(f"{PROG} {args.verb_name}")
    except BrokenPipeError:  # `| head`: the reader left; nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except OSError as exc:  # --svg FILE cannot be written
        print(f"error: cannot write {cut(str(args.svg))}: {exc.strerror}", file=sys.stderr)
        code = code or 1
    return code

