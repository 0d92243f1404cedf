"""The state every room of the ``Handler`` shares, and the record of one loop step."""
from __future__ import annotations

import collections
import logging
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable

from ..bus import PreparedWrite, ServoBus
from ..config import Config
from ..servos import PendingWrites, ServoTable

if TYPE_CHECKING:
    from .read_plan import _Read


#: a servo that stopped answering is pinged every RECHECK_LOOPS loops, or every RECHECK_S at loop
#: rates under RECHECK_LOOPS / RECHECK_S (a glitch at 2 Hz then costs one loop's read, not ten)
RECHECK_LOOPS = 10
RECHECK_S = 0.1


def recheck_loops(loop_rate: float) -> int:
    """Loops between pings of a servo that stopped answering at ``loop_rate`` [Hz]."""
    return max(1, min(RECHECK_LOOPS, round(RECHECK_S * loop_rate)))


@dataclass
class StepReport:
    loop: int
    stamp: float = 0.0                       # wall-clock time of the reads (time.time())
    groups: set[str] = field(default_factory=set)        # groups read: status, goal, gain, ...
    present: set[str] = field(default_factory=set)       # present keys read: pwm, current, ...
    read_s: float = 0.0
    # the step's work between its phases (Handler.begin_step ... Handler.finish_step)
    reads: list[list[Any]] = field(default_factory=list, repr=False)  # [_Read, GroupRead, data or None]
    recheck: list[int] = field(default_factory=list, repr=False)  # silent IDs pinged after the reads
    silent: list[int] = field(default_factory=list, repr=False)   # IDs addressed that did not answer
    seq: int = 0                                                  # ServoTable.seq when the reads went out
    phase: int = 0                                                # 1 begun, 2 sent, 3 complete, 4 finished


class HandlerState:
    """What the rooms share: the bus, the parameters, the servo table and the bookkeeping of
    each room (set here, so that every attribute has one place where it is born)."""

    def __init__(self, bus: ServoBus, config: Config, logger: logging.Logger | None = None) -> None:
        self.bus = bus
        self.config = config
        self.log = logger or logging.getLogger("dynamixel_handler")
        self.table = ServoTable()
        self.pending = PendingWrites()
        self.loop_count = 0
        self.recheck_loops = recheck_loops(config["loop_rate"])
        self._ops: collections.deque[tuple[str, Callable[[], None]]] = collections.deque()
        self._ops_lock = threading.Lock()
        self._plans: dict[tuple[tuple[str, ...], bytes], list[_Read]] = {}
        self._plans_version = -1
        # loops' due items by the pattern of ratios that divide the loop number (read_plan.py)
        self._due_config: Config | None = None
        self._due_cache: dict[tuple[bool, tuple[int, ...]], Any] = {}
        self._due_ratios: tuple[int, ...] = ()
        self._plain_read: set[int] = set()  # IDs that do not answer Fast Sync Read
        self._fast_misses: dict[int, int] = {}  # ID -> fast reads in a row that stopped at it while it answered plain
        # writes taken from ``pending`` but not sent yet (encode_writes): {(address, size): {id: bytes}}
        # per item, and their packets, built for ServoTable.version ``_built_for``. Kept here, not in a
        # StepReport, so that a loop that fails between taking and sending them loses nothing.
        self._taken: dict[tuple[int, int], dict[int, bytes]] = {}
        self._prepared: list[PreparedWrite] = []
        self._built_for = -1
        self.fast_read = bool(config["method/fast_read"])
        self.split_read = bool(config["method/split_read"])
        self.split_write = bool(config["method/split_write"])
        self.reconnects = 0
        self.device_lost = False
        self.device_lost_since: float | None = None  # time.time() when the device was found gone
        self._had_device = False
        # the loop period the bus watchdog time derives from: the longer of 1 / loop_rate and the
        # one measured (or, before the first loops, estimated from the wire time of a loop's reads)
        self.loop_period_s = 0.0
        self._watchdog_warned = False
        self._next_reconnect = 0.0
        self.watchdog_trips = 0
        self._reported_errors: dict[int, int] = {}
        self._to_arm: set[int] = set()  # servos whose bus watchdog is armed at the next step
        self._check_watchdogs = False  # bus watchdogs were read: clear the tripped ones at the next step
        self.watchdog_user: dict[int, int] = {}  # ID -> bus watchdog pulses a command asked for
        self._last_mode_change: dict[int, float] = {}  # ID -> time.monotonic() of its last mode change
        self._last_clear: dict[int, float] = {}  # ID -> time.monotonic() of its last error clear
        self._eeprom_written: dict[tuple[int, str], float] = {}  # (ID, item) -> time of the last write
        self._eeprom_deferred: dict[tuple[int, str], int] = {}  # (ID, item) -> value to write when due
        # ID -> (monotonic time when due, what, operation): per-servo work that must wait (a mode
        # change asked for too soon after the last one); a later request for the servo replaces it
        self.deferred: dict[int, tuple[float, str, Callable[[], None]]] = {}
        #: why operations are not taken now (a lifecycle node that is not active); None: they are
        self.refuse_ops: str | None = None
        #: true once the node is asked to exit: start-up (scan, set-up) stops between two steps
        self.interrupted: Callable[[], bool] = lambda: False
