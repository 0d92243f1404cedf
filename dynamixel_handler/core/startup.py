"""Start-up: the scan, the servos kept, each set up (``servo_setup``; also when added later)."""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable, Sequence

from ..bus import ServoBus, dummy_ids
from ..bus.ops import Ping
from ..errors import Interrupted, StartupError
from ..servo.table import ServoTable
from ..settings import ScanSettings
from .log_limits import LogLimits
from .scan import UNKNOWN_MODEL_HELP, Scan, Seen, lookup, none_handled
from .servo_io import Log
from .servo_setup import ServoSetup


@dataclass(frozen=True)
class StartupSettings:
    scan: ScanSettings = ScanSettings()     # which servos are looked for
    debug: bool = False                     # a start-up problem is logged and the node runs on


class Startup:
    """Scan, expected count, each servo set up (``ServoSetup``), add_id. ``interrupted()`` tells
    that the node is asked to exit (the scan and the set-up stop between two servos)."""

    def __init__(self, bus: ServoBus, table: ServoTable, log: Log, setup: ServoSetup, settings: StartupSettings,
                 interrupted: Callable[[], bool]) -> None:
        self.bus = bus
        self.table = table
        self.log = log
        self.setup = setup
        self.kept = setup.kept
        self.settings = settings
        self.interrupted = interrupted
        self.limited = LogLimits(lambda level, msg: self.log.log(level, msg))
        #: ID -> handled or not, as commands asked in this loop (``want_handled``); None: nothing asked
        self.membership: dict[int, bool] | None = None
        #: whether start-up reached its first write (a refusal before it leaves every servo as found)
        self.wrote = False
        self.scanning = Scan(bus, log, settings.scan, self._startup_problem, interrupted)

    def start(self) -> None:
        """Scan, keep the servos of the used series, and set each up as the parameters say."""
        self.wrote = False
        dummies = dummy_ids(self.bus)
        expected = self.settings.scan.expected
        self.scanning.settings = self.settings.scan
        found = self.scanning.scan(dummies, expected)
        self._keep(found, dummies)
        if expected > 0 and len(self.table) != expected:
            message = (f"handling {len(self.table)} servo(s) {list(self.table.ids)} on {self.bus.device}, but "
                       f"init/expected_servo_num is {expected}: check the IDs on the bus, or set "
                       "init/expected_servo_num (0: any number)")
            self._startup_problem(message)
        self.kept.check(self.settings.debug)  # before anything is written
        self.wrote = True
        for dxl_id in list(self.table.ids):
            if self.interrupted():
                raise Interrupted(f"start-up interrupted while setting up the servos (at ID {dxl_id})")
            self.setup.setup_servo(dxl_id)

    def _keep(self, found: dict[int, Seen], dummies: Sequence[int]) -> None:
        """Put the servos found that are known models of a used series (or dummies) in the table."""
        used = set(self.settings.scan.used_series)
        for dxl_id, seen in sorted(found.items()):
            model = lookup(seen)
            if model is None:
                self.log.warning(f"ID {dxl_id}: unknown model number {seen[1]}"
                                 f"{' (Protocol 1.0)' if seen[0] == 1 else ''}, not handled: {UNKNOWN_MODEL_HELP}")
                continue
            if model.series not in used and dxl_id not in dummies:
                self.log.info(f"ID {dxl_id}: {model.name} is series {model.series}, which "
                              f"init/used_servo_series does not enable: skipped")
                continue
            self.table.add(dxl_id, model)
            kind = "dummy" if dxl_id in dummies else f"model {seen[1]}"
            self.log.info(f"ID {dxl_id}: {model.name} ({kind}, series {model.series}"
                          f"{model.family.protocol_note}) handled")
        if not len(self.table) and found and not self.settings.debug:
            none_handled(found, used)

    def _startup_problem(self, message: str) -> None:
        """Start-up cannot go on (StartupError), unless the debug parameter says to run on anyway."""
        if not self.settings.debug:
            raise StartupError(message)
        self.log.warning(message + " (debug: running on)")

    def want_handled(self, dxl_id: int, handled: bool) -> None:
        """add_id (True) or remove_id (False) from a command, applied once the queued operations of
        this loop have run: the last request for an ID in a loop wins, so a script that adds and
        removes a servo many times a loop costs at most one change a loop."""
        if self.membership is None:
            self.membership = {}
        self.membership.pop(dxl_id, None)
        self.membership[dxl_id] = handled

    def apply_membership(self) -> None:
        """The add_id / remove_id requests of this loop (a removal: the table lets the servo go,
        the parts that watch it forget it)."""
        wanted, self.membership = self.membership or {}, None
        for dxl_id, handled in wanted.items():
            if not handled:
                self.table.remove(dxl_id)
            elif dxl_id not in self.table:
                self.add_id(dxl_id)

    def add_id(self, dxl_id: int) -> bool:
        """Ping ``dxl_id`` and handle it if it answers with a model of a used series (in Protocol
        1.0 too where a Protocol 1.0 family is used)."""
        seen: Seen | None = None
        number = self.bus.execute(Ping(dxl_id, protocol=2)).value
        if number is not None:
            seen = (2, number)
        elif self.scanning.protocol1():
            seen = self.scanning.ping1([dxl_id]).get(dxl_id)
        if seen is None:
            self.limited(logging.WARNING, f"ID {dxl_id}: no answer to ping, not added", f"not added {dxl_id}")
            return False
        model = lookup(seen)
        if model is None:
            self.limited(logging.WARNING, f"ID {dxl_id}: unknown model number {seen[1]}, not added", f"not added {dxl_id}")
            return False
        if model.series not in self.settings.scan.used_series:
            self.limited(logging.WARNING, f"ID {dxl_id}: {model.name} is series {model.series}, not enabled in "
                         "init/used_servo_series", f"not added {dxl_id}")
            return False
        self.table.add(dxl_id, model)
        self.limited(logging.INFO, f"ID {dxl_id}: {model.name} added", f"added {dxl_id}")
        self.setup.setup_servo(dxl_id)  # the same set-up as at start-up
        return True
