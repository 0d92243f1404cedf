"""The handler's life on the bus: start-up, one loop step, shutdown. ROS-free.

``Handler.step()`` runs queued operations (torque, mode, reboot...), writes pending values in
grouped sync writes, reads what the ratios ask for this loop, and returns a ``StepReport`` that
says which groups were read. The ROS layer turns the table into messages.
"""
from __future__ import annotations

import collections
import logging
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from . import units
from .bus import ServoBus
from .config import Config
from .control_table import OPERATING_MODES, model_by_number
from .errors import Interrupted, StartupError
from .groups import GROUP_ITEMS, GROUP_RATIO_PARAM, MODE_NAMES, PRESENT, due
from .servos import PendingWrites, ServoTable

#: items closer than this many bytes are read in one span when method/split_read is false
SPAN_GAP = 24
#: loops between pings of a servo that stopped answering
RECHECK_LOOPS = 10
#: Fast Sync Reads in a row that must stop at a servo which answers the plain Sync Read before it is
#: taken for firmware without Fast Sync Read (a garbled reply or a neighbour's silence does it once)
FAST_MISSES_PLAIN = 3
#: longest wait for a servo to answer again after a reboot instruction [s]
REBOOT_WAIT_S = 1.0
#: least time between two attempts to reopen a vanished device [s]
RECONNECT_INTERVAL_S = 1.0
#: bus watchdog register value (signed) of a servo whose watchdog has tripped
WATCHDOG_TRIPPED = -1
#: operating modes in which the bus watchdog is armed: a servo in a position mode holds its goal
#: by itself, and a watchdog trip in a position mode with a homing offset moves the shaft by the
#: offset (a firmware fault the original handler works around the same way)
WATCHDOG_MODES = frozenset({"velocity", "current", "pwm"})
#: least time between two writes of one EEPROM item of one servo [s]; a value asked for sooner is
#: written when the time has passed (the latest one asked for)
EEPROM_WRITE_INTERVAL_S = 1.0
#: longest bus watchdog time the register holds (127 x 20 ms)
WATCHDOG_MAX_MS = 2540.0


@dataclass
class StepReport:
    loop: int
    stamp: float = 0.0                       # wall-clock time of the reads (time.time())
    groups: set[str] = field(default_factory=set)        # groups read: status, goal, gain, ...
    present: set[str] = field(default_factory=set)       # present keys read: pwm, current, ...
    read_s: float = 0.0
    write_s: float = 0.0
    removed: list[int] = field(default_factory=list)
    # the step's work between its phases (Handler.begin_step ... Handler.finish_step)
    reads: list[list] = field(default_factory=list, repr=False)   # [_Read, GroupRead, data or None]
    recheck: list[int] = field(default_factory=list, repr=False)  # silent IDs pinged after the reads
    silent: list[int] = field(default_factory=list, repr=False)   # IDs addressed that did not answer
    seq: int = 0                                                  # ServoTable.seq when the reads went out
    phase: int = 0                                                # 1 begun, 2 sent, 3 complete, 4 finished


@dataclass(frozen=True)
class _Part:
    item: str
    offset: int
    size: int
    signed: bool


@dataclass(frozen=True)
class _Read:
    address: int
    length: int
    ids: tuple[int, ...]
    parts: tuple[_Part, ...]
    fast: bool = False


class Handler:
    """Owns the servos of one bus."""

    def __init__(self, bus: ServoBus, config: Config, logger: logging.Logger | None = None) -> None:
        self.bus = bus
        self.config = config
        self.log = logger or logging.getLogger("dynamixel_handler")
        self.table = ServoTable()
        self.pending = PendingWrites()
        self.loop_count = 0
        self._ops: collections.deque[tuple[str, Callable[[], None]]] = collections.deque()
        self._ops_lock = threading.Lock()
        self._plans: dict[tuple, list[_Read]] = {}
        self._plans_version = -1
        self._plain_read: set[int] = set()  # IDs that do not answer Fast Sync Read
        self._fast_misses: dict[int, int] = {}  # ID -> fast reads in a row that stopped at it while it answered plain
        # writes taken from ``pending`` but not sent yet (encode_writes): {(address, size): {id: bytes}}
        # per item, and their packets, built for ServoTable.version ``_built_for``. Kept here, not in a
        # StepReport, so that a loop that fails between taking and sending them loses nothing.
        self._taken: dict[tuple[int, int], dict[int, bytes]] = {}
        self._prepared: list = []
        self._built_for = -1
        self.fast_read = bool(config["method/fast_read"])
        self.split_read = bool(config["method/split_read"])
        self.split_write = bool(config["method/split_write"])
        self.stats_reads = 0
        self.stats_full_reads = 0
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
        self._eeprom_written: dict[tuple[int, str], float] = {}  # (ID, item) -> time of the last write
        self._eeprom_deferred: dict[tuple[int, str], int] = {}  # (ID, item) -> value to write when due
        # ID -> (monotonic time when due, what, operation): per-servo work that must wait (a mode
        # change asked for too soon after the last one); a later request for the servo replaces it
        self.deferred: dict[int, tuple[float, str, Callable[[], None]]] = {}
        #: why operations are not taken now (a lifecycle node that is not active); None: they are
        self.refuse_ops: str | None = None
        #: true once the node is asked to exit: start-up (scan, set-up) stops between two steps
        self.interrupted: Callable[[], bool] = lambda: False

    # ================================================================ start-up
    def start(self) -> None:
        """Scan, keep the servos of the used series, and set each up as the parameters say."""
        cfg = self.config
        self._had_device = self.bus.is_open
        lo, hi = cfg["init/servo_auto_search.min_id"], cfg["init/servo_auto_search.max_id"]
        dummies = sorted(self.bus.dummies)
        expected = cfg["init/expected_servo_num"]
        attempts = cfg["init/servo_auto_search.retry_times"] + 1
        found: dict[int, int] = {}
        for attempt in range(attempts):
            if self.interrupted():
                raise Interrupted(f"start-up interrupted during the scan (attempt {attempt + 1}/{attempts})")
            found.update(self.bus.scan(sorted(set(range(lo, hi + 1)) | set(dummies))))
            enough = len(self._usable(found, dummies)) >= expected if expected > 0 else len(found) >= 1
            real = sorted(set(found) - set(dummies))
            self.log.info(f"scan {attempt + 1}/{attempts} of IDs {lo}..{hi} on {self.bus.device} at "
                          f"{self.bus.baudrate} bps: {len(real)} servo(s) {real}"
                          + (f" + dummies {dummies}" if dummies else ""))
            if enough or not self.bus.is_open:
                break
        enough = len(self._usable(found, dummies)) >= expected if expected > 0 else len(found) >= 1
        if not enough:
            want = f"{expected}" if expected > 0 else "at least 1"
            message = (f"found {len(found)} servo(s) on {self.bus.device} at {self.bus.baudrate} bps, expected "
                       f"{want}: check power, wiring, IDs ({lo}..{hi}) and baudrate "
                       "(init/baudrate_auto_set can find servos at other rates)")
            self._startup_problem(message)
        used = set(cfg.used_series)
        for dxl_id, number in sorted(found.items()):
            try:
                model = model_by_number(number)
            except KeyError:
                self.log.warning(f"ID {dxl_id}: unknown model number {number}, not handled")
                continue
            if model.series not in used and dxl_id not in dummies:
                self.log.info(f"ID {dxl_id}: {model.name} is series {model.series}, which "
                              f"init/used_servo_series does not enable: skipped")
                continue
            self.table.add(dxl_id, model)
            kind = "dummy" if dxl_id in dummies else f"model {number}"
            self.log.info(f"ID {dxl_id}: {model.name} ({kind}, series {model.series}) handled")
        if not len(self.table) and found and not cfg["debug"]:
            raise StartupError(f"no servo of the used series ({'/'.join(sorted(used))}) among IDs "
                               f"{sorted(found)}: enable their series in init/used_servo_series")
        if expected > 0 and len(self.table) != expected:
            message = (f"handling {len(self.table)} servo(s) {list(self.table.ids)} on {self.bus.device}, but "
                       f"init/expected_servo_num is {expected}: check the IDs on the bus, or set "
                       "init/expected_servo_num (0: any number)")
            self._startup_problem(message)
        for dxl_id in list(self.table.ids):
            if self.interrupted():
                raise Interrupted(f"start-up interrupted while setting up the servos (at ID {dxl_id})")
            self._setup_servo(dxl_id)

    def _startup_problem(self, message: str) -> None:
        """Start-up cannot go on (StartupError), unless the debug parameter says to run on anyway."""
        if not self.config["debug"]:
            raise StartupError(message)
        self.log.warning(message + " (debug: running on)")

    def _usable(self, found: dict[int, int], dummies: Sequence[int]) -> list[int]:
        """IDs among ``found`` that would be handled: known model of a used series, or a dummy."""
        used = set(self.config.used_series)
        out = []
        for dxl_id, number in found.items():
            try:
                series = model_by_number(number).series
            except KeyError:
                continue
            if series in used or dxl_id in dummies:
                out.append(dxl_id)
        return out

    def _setup_servo(self, dxl_id: int) -> None:
        """The set-up every servo gets, at start-up and when added later (add_id): hardware error
        cleared (init/hardware_error_auto_clean), return delay, profile defaults, torque as
        init/torque_auto_enable says; the bus watchdog when the loop next runs."""
        cfg, model = self.config, self.table.model(dxl_id)
        if cfg["init/hardware_error_auto_clean"]:
            err = self.read_item(dxl_id, "hardware_error_status")
            if err:
                self.log.warning(f"ID {dxl_id}: hardware error 0x{err:02X} at start-up: clearing it by reboot")
                self.reboot(dxl_id)
        delay = int(units.unit_to_pulse([model], "return_delay_time", [cfg["default/return_delay_time"]])[0])
        self.write_eeprom(dxl_id, "return_delay_time", delay)
        self._setup_ram(dxl_id)
        if cfg["init/torque_auto_enable"]:
            self.torque_on(dxl_id)

    def _setup_ram(self, dxl_id: int) -> None:
        """Profile defaults now; the bus watchdog when the loop starts (arming it here, servo by
        servo, would let it trip on the first servos while the last ones are still set up)."""
        model = self.table.model(dxl_id)
        for item, param in (("profile_acceleration", "default/profile_acc"), ("profile_velocity", "default/profile_vel")):
            if model.has(item):
                pulses = int(units.unit_to_pulse([model], item, [self.config[param]])[0])
                if not self.write_item(dxl_id, item, pulses):  # e.g. above a P servo's velocity limit
                    self.log.warning(f"ID {dxl_id} ({model.name}): {param} = {self.config[param]:g} not set "
                                     f"({item} {pulses} refused: {self.bus.last_failure})")
        self._to_arm.add(dxl_id)

    def watchdog_pulses(self) -> int:
        """Bus watchdog register value (20 ms units, 0 = off): default/bus_watchdog, but at least three
        times the longest gap between two reads of a servo, so a healthy loop never trips it."""
        cfg = self.config
        if not cfg["term/servo_auto_stop"] or cfg["default/bus_watchdog"] <= 0:
            return 0
        ratios = [cfg.present_ratio(k) for k in PRESENT] + [cfg[p] for p in GROUP_RATIO_PARAM.values()]
        every = min((r for r in ratios if r > 0), default=0)
        if every == 0:
            return 0  # nothing is read after start-up: a watchdog would stop every servo
        period = max(1.0 / cfg["loop_rate"], self.loop_period_s)
        ms = max(cfg["default/bus_watchdog"], 3000.0 * every * period)
        if ms > WATCHDOG_MAX_MS and not self._watchdog_warned:
            self._watchdog_warned = True
            self.log.warning(f"bus watchdog: a servo is addressed every {1000 * every * period:.0f} ms, so it needs "
                             f"{ms:.0f} ms, but the register holds at most {WATCHDOG_MAX_MS:g} ms: set to that, a servo "
                             "may stop between two loops (lower the bus time per loop: fewer reads, higher baudrate)")
        return int(min(127, max(1, round(ms / 20.0))))

    def note_loop_period(self, seconds: float) -> None:
        """The loop period measured (or estimated): when it moves the bus watchdog time (longer by a
        quarter, or shorter by half), the servos that have the automatic one get it anew."""
        old = self.loop_period_s
        if old and old / 2 < seconds < old * 1.25:
            return
        before = self.watchdog_pulses()
        self.loop_period_s = seconds
        if self.watchdog_pulses() != before:
            self._to_arm.update(i for i in self.table.ids
                                if i not in self.watchdog_user and self.mode(i) in WATCHDOG_MODES)

    def estimate_loop_s(self) -> float:
        """Wire time of the reads over every handled servo (instruction and replies at the baud
        rate, plus the adapter's latency each way) per loop, on average over the loops between two
        reads of the most often read items: the loop period before one is measured."""
        if not len(self.table) or not self.bus.baudrate:
            return 0.0
        cfg = self.config
        ratios = [cfg.present_ratio(k) for k in PRESENT] + [cfg[p] for p in GROUP_RATIO_PARAM.values()]
        every = min((r for r in ratios if r > 0), default=0)
        items, _, _ = self.due_items(every)  # the loop that reads the most often read items
        if not every or not items:
            return 0.0
        live = np.ones(len(self.table), dtype=bool)
        byte_s = 10.0 / self.bus.baudrate
        latency_s = 2 * self.bus.latency_timer_ms / 1000.0
        total = 0.0
        for read in self._plan(tuple(sorted(set(items))), live):
            n = len(read.ids)
            total += (14 + n + n * (11 + read.length)) * byte_s + latency_s
        return total / every  # per loop, on average

    def watchdog_for(self, dxl_id: int) -> int:
        """The bus watchdog this servo should have [20 ms pulses, 0 = off]: the value a command
        set for it (extra bus_watchdog_ms), else the automatic one (``watchdog_pulses``) in
        velocity, current and PWM modes, else off."""
        if dxl_id in self.watchdog_user:
            return self.watchdog_user[dxl_id]
        return self.watchdog_pulses() if self.mode(dxl_id) in WATCHDOG_MODES else 0

    def arm_watchdog(self, dxl_id: int) -> None:
        """So that a crashed or killed node still stops its servos: the servo stops by itself when
        no instruction has reached it for the watchdog time (X and P; the old Pro has none). Also
        clears a tripped watchdog (a tripped servo refuses goals), and switches it off where the
        servo's mode needs none."""
        if not self.table.model(dxl_id).has("bus_watchdog"):
            return
        pulses = self.watchdog_for(dxl_id)
        if self.table.value("bus_watchdog", dxl_id) != 0:
            self.write_item(dxl_id, "bus_watchdog", 0)  # first 0: clears a trip, allows a new value
        if pulses:
            self.write_item(dxl_id, "bus_watchdog", pulses)

    def clear_tripped(self, ids: Sequence[int]) -> None:
        """Before goals go to these servos: a bus watchdog known to have tripped is cleared and
        armed again, or the servo would refuse the goals."""
        table = self.table
        known, values = table.known("bus_watchdog"), table.pulses("bus_watchdog")
        for dxl_id in ids:
            pos = table.index.get(dxl_id)
            if pos is not None and known[pos] and values[pos] < 0:
                self.watchdog_trips += 1
                self.log.warning(f"ID {dxl_id}: bus watchdog had tripped: cleared and armed again before the new goal")
                self.arm_watchdog(dxl_id)

    # ================================================================ single-servo helpers
    def read_item(self, dxl_id: int, item: str) -> int | None:
        model = self.table.model(dxl_id)
        if not model.has(item):
            return None
        spec = model.item(item)
        data = self.bus.read(dxl_id, spec.address, spec.size)
        if data is None:
            return None
        value = int(units.decode(spec, data)[0])
        self.table.set_value(item, dxl_id, value)
        return value

    def write_item(self, dxl_id: int, item: str, pulses: int) -> bool:
        model = self.table.model(dxl_id)
        if not model.has(item):
            return False
        spec = model.item(item)
        ok = self.bus.write(dxl_id, spec.address, units.encode(spec, [pulses]))
        if ok:
            self.table.set_value(item, dxl_id, pulses)
        return ok

    def write_eeprom(self, dxl_id: int, item: str, pulses: int) -> bool:
        """Write one EEPROM item (see ``write_eeprom_many``)."""
        if not self.table.model(dxl_id).has(item):
            return False
        return self.write_eeprom_many(dxl_id, {item: pulses})

    def write_eeprom_many(self, dxl_id: int, values: dict[str, int]) -> bool:
        """Write EEPROM items of one servo, sparing its EEPROM: a value equal to the servo's is not
        written; an item written less than EEPROM_WRITE_INTERVAL_S ago is written when that time
        has passed (the latest value asked for). Torque goes off for the write and comes back on
        safely (goals := present state first), so the servo does not jump to an old goal.
        False if a write failed."""
        model = self.table.model(dxl_id)
        now = time.monotonic()
        todo: dict[str, int] = {}
        for item, pulses in values.items():
            if not model.has(item):
                continue
            key = (dxl_id, item)
            if self.read_item(dxl_id, item) == pulses:
                self._eeprom_deferred.pop(key, None)  # already so: nothing to write, nothing later
                continue
            last = self._eeprom_written.get(key)
            if last is not None and now - last < EEPROM_WRITE_INTERVAL_S:
                if key not in self._eeprom_deferred:
                    self.log.info(f"ID {dxl_id}: {item} was written {now - last:.2f}s ago: {item}={pulses} "
                                  f"is written {EEPROM_WRITE_INTERVAL_S:g}s after it (EEPROM wear)")
                self._eeprom_deferred[key] = pulses
                continue
            self._eeprom_deferred.pop(key, None)
            todo[item] = pulses
        if not todo:
            return True
        torque = self.read_item(dxl_id, "torque_enable")
        if torque:
            self.write_item(dxl_id, "torque_enable", 0)
        ok = True
        for item, pulses in todo.items():
            if self.write_item(dxl_id, item, pulses):
                self._eeprom_written[(dxl_id, item)] = time.monotonic()
            else:
                ok = False
                self.log.warning(f"ID {dxl_id}: writing {item}={pulses} failed: {self.bus.last_failure}")
        if torque:
            self.torque_on(dxl_id)
        return ok

    def _run_deferred(self) -> None:
        """EEPROM values and per-servo operations that had to wait, once their time has come."""
        now = time.monotonic()
        if self._eeprom_deferred:
            due_ids = {i for (i, item) in self._eeprom_deferred
                       if now - self._eeprom_written.get((i, item), 0.0) >= EEPROM_WRITE_INTERVAL_S}
            for dxl_id in sorted(due_ids):
                values = {item: v for (i, item), v in list(self._eeprom_deferred.items()) if i == dxl_id}
                if dxl_id not in self.table:
                    for item in values:
                        self._eeprom_deferred.pop((dxl_id, item), None)
                    continue
                self.write_eeprom_many(dxl_id, values)
        for dxl_id, (when, what, op) in list(self.deferred.items()):
            if when > now:
                continue
            del self.deferred[dxl_id]
            if dxl_id not in self.table:
                continue
            try:
                op()
            except Exception as exc:  # an operation must never stop the loop
                self.log.error(f"{what} failed: {type(exc).__name__}: {exc}")

    def reboot(self, dxl_id: int) -> bool:
        """Reboot and wait until the servo answers again (it needs a few hundred ms; this blocks the
        loop meanwhile, so that nothing is sent to a servo that is still booting)."""
        # a reboot resets the RAM area: what the handler had set there comes back afterwards
        kept = {item: self.table.value(item, dxl_id) for item in ("profile_acceleration", "profile_velocity")}
        ok = self.bus.reboot(dxl_id)
        if ok:
            deadline = time.monotonic() + REBOOT_WAIT_S
            time.sleep(0.02)
            while self.bus.ping(dxl_id, retries=0) is None:
                if time.monotonic() > deadline:
                    self.log.warning(f"ID {dxl_id}: no answer {REBOOT_WAIT_S:g}s after reboot")
                    break
                time.sleep(0.02)
            for item, value in kept.items():
                if value is not None:
                    self.write_item(dxl_id, item, value)
            if dxl_id in self.table:
                self.arm_watchdog(dxl_id)
        return ok

    def mode(self, dxl_id: int) -> str | None:
        value = self.table.value("operating_mode", dxl_id)
        if value is None:
            value = self.read_item(dxl_id, "operating_mode")
        return MODE_NAMES.get(value) if value is not None else None

    def torque_on(self, dxl_id: int) -> bool:
        """Enable torque without a jump: goals := present state (position) or neutral, then enable."""
        mode = self.mode(dxl_id)
        model = self.table.model(dxl_id)
        if mode in ("position", "ex_position", "cur_position"):
            present = self.read_item(dxl_id, "present_position")
            if present is not None:
                if mode == "position":
                    present = self._clip_to_position_limits(dxl_id, present)
                self.write_item(dxl_id, "goal_position", present)
        elif mode == "velocity":
            self.write_item(dxl_id, "goal_velocity", 0)
        elif mode == "current":
            self.write_item(dxl_id, "goal_current", 0)
        elif mode == "pwm":
            self.write_item(dxl_id, "goal_pwm", 0)
        ok = self.write_item(dxl_id, "torque_enable", 1)
        if not ok:
            self.log.warning(f"ID {dxl_id} ({model.name}): torque on failed: {self.bus.last_failure}")
        return ok

    def torque_off(self, dxl_id: int) -> bool:
        return self.write_item(dxl_id, "torque_enable", 0)

    def _clip_to_position_limits(self, dxl_id: int, pulses: int) -> int:
        lo = self.table.value("min_position_limit", dxl_id)
        hi = self.table.value("max_position_limit", dxl_id)
        if lo is None:
            lo = self.read_item(dxl_id, "min_position_limit")
        if hi is None:
            hi = self.read_item(dxl_id, "max_position_limit")
        if lo is not None and hi is not None and lo <= hi:
            return min(max(pulses, lo), hi)
        return pulses

    # ================================================================ membership
    def add_id(self, dxl_id: int) -> bool:
        """Ping ``dxl_id`` and handle it if it answers with a model of a used series."""
        number = self.bus.ping(dxl_id)
        if number is None:
            self.log.warning(f"ID {dxl_id}: no answer to ping, not added")
            return False
        try:
            model = model_by_number(number)
        except KeyError:
            self.log.warning(f"ID {dxl_id}: unknown model number {number}, not added")
            return False
        if model.series not in self.config.used_series:
            self.log.warning(f"ID {dxl_id}: {model.name} is series {model.series}, not enabled in init/used_servo_series")
            return False
        self.table.add(dxl_id, model)
        self.log.info(f"ID {dxl_id}: {model.name} added")
        self._setup_servo(dxl_id)  # the same set-up as at start-up
        return True

    def remove_id(self, dxl_id: int) -> None:
        if dxl_id in self.table:
            self.table.remove(dxl_id)
            self.pending.drop_ids([dxl_id])
            self.deferred.pop(dxl_id, None)
            self.watchdog_user.pop(dxl_id, None)
            for key in [k for k in self._eeprom_deferred if k[0] == dxl_id]:
                del self._eeprom_deferred[key]
            self.log.info(f"ID {dxl_id}: removed from the handled servos")

    # ================================================================ operations from callbacks
    def queue(self, what: str, op: Callable[[], None]) -> None:
        """Run ``op`` in the loop thread at the start of the next step (callbacks never touch the bus)."""
        with self._ops_lock:
            self._ops.append((what, op))

    def drop_ops(self) -> int:
        """Forget the queued operations (the loop does not run); how many there were."""
        with self._ops_lock:
            count = len(self._ops)
            self._ops.clear()
        return count

    def _run_ops(self) -> None:
        while True:
            with self._ops_lock:
                if not self._ops:
                    return
                what, op = self._ops.popleft()
            try:
                op()
            except Exception as exc:  # an operation must never stop the loop
                self.log.error(f"{what} failed: {type(exc).__name__}: {exc}")

    # ================================================================ the loop step
    def step(self) -> StepReport:
        """One whole loop: queued operations, pending writes, the reads due, bookkeeping."""
        report = self.begin_step()
        self.send_step(report)
        self.finish_step(report)
        return report

    # A step in four phases, so that a caller can overlap one loop's reads on the wire with work
    # that needs no bus (the node takes the next commands and publishes the previous states then):
    #   begin_step     reconnect, watchdog arming, queued operations (``prepare``)
    #   send_step      the pending writes (send_writes), then the reads due (send_reads); the last
    #                  read is left on the wire
    #   complete_step  its replies gathered, Fast Sync Read fallback, pings of silent servos, ping state
    #   finish_step    replies stored in the table, read logs, tripped watchdogs re-armed
    # Any bus transaction in between first waits for the read on the wire (``ServoBus``).
    def begin_step(self) -> StepReport:
        report = StepReport(loop=self.loop_count, phase=1)
        self.prepare(report)
        return report

    def prepare(self, report: StepReport) -> None:
        """Reopen a vanished device, arm watchdogs, run the queued operations (commands). Called
        by ``begin_step``, and again before ``send_step`` for commands that came meanwhile."""
        if self._had_device and not self.bus.is_open:
            self._reconnect(report)
        while self._to_arm:
            dxl_id = self._to_arm.pop()
            if dxl_id in self.table:
                self.arm_watchdog(dxl_id)
        if self._check_watchdogs:
            self._check_watchdogs = False
            self.check_watchdogs()
        if self.deferred or self._eeprom_deferred:
            self._run_deferred()
        self._run_ops()

    def apply_now(self) -> None:
        """Between loops: run the queued operations and write what they left pending at once."""
        report = StepReport(loop=self.loop_count)
        self.prepare(report)
        self._send_writes(report)

    def _send_writes(self, report: StepReport) -> None:
        t0 = time.perf_counter()
        self.encode_writes()
        if self._taken and self._built_for != self.table.version:  # servos removed meanwhile
            self._build_writes()
        prepared, self._prepared, self._taken = self._prepared, [], {}
        for write in prepared:
            if not self.bus.send_prepared(write):
                self.log.warning(f"sync write @{write.address}x{write.length} to IDs "
                                 f"{sorted((*write.ids, *write.dummies))} failed: {self.bus.last_failure}")
        report.write_s += time.perf_counter() - t0

    def encode_writes(self) -> None:
        """Take the pending values and build their sync write packets now; the next
        ``send_writes`` sends them (with what became pending meanwhile, a later value of a servo's
        item winning). The node does this while a read is on the wire, so the packets are ready the
        moment it is free."""
        fresh = self._encode_pending()
        if not fresh:
            return
        for key, data in fresh.items():
            self._taken.setdefault(key, {}).update(data)
        self._build_writes()

    @property
    def writes_ready(self) -> list:
        """The sync writes built by ``encode_writes`` and not sent yet (``PreparedWrite``)."""
        return list(self._prepared)

    def _build_writes(self) -> None:
        index = self.table.index
        writes = {key: kept for key, data in self._taken.items()
                  if (kept := {i: chunk for i, chunk in data.items() if i in index})}
        if not self.split_write:
            writes = _merge_adjacent_writes(writes)
        self._prepared = [self.bus.prepare_sync_write(address, size, data)
                          for (address, size), data in sorted(writes.items())]
        self._built_for = self.table.version

    def send_step(self, report: StepReport) -> None:
        self.send_writes(report)
        self.send_reads(report)

    def send_writes(self, report: StepReport) -> None:
        """The first half of ``send_step``: what is pending goes on the wire."""
        self._send_writes(report)

    def await_replies(self, report: StepReport) -> None:
        """Wait until the replies of ``report``'s reads are in (``complete_step`` does the rest)."""
        for _, pending, _ in report.reads:
            pending.result()

    def send_reads(self, report: StepReport) -> None:
        """The second half of ``send_step``: the reads due; the last one is left on the wire."""
        report.phase = 2
        self.loop_count = report.loop + 1  # a loop that failed before its reads keeps its number
        report.read_s = -time.perf_counter()
        report.stamp = time.time()
        report.seq = self.table.seq
        if not len(self.table):
            return
        items, report.present, report.groups = self.due_items(report.loop)
        live = self.table.ping.copy()
        if items:
            for read in self._plan(tuple(sorted(set(items))), live):
                report.reads.append([read, self.bus.start_sync_read(read.address, read.length, read.ids, fast=read.fast), None])
        # servos that stopped answering are pinged now and then, not read every loop
        if report.loop % RECHECK_LOOPS == 0:
            report.recheck = [self.table.ids[pos] for pos in np.flatnonzero(~live)]

    @property
    def reply_eta(self) -> float | None:
        """``time.monotonic()`` by which the read left on the wire should be answered (None: none is)."""
        return self.bus.inflight_eta

    def complete_step(self, report: StepReport) -> None:
        if report.phase >= 3:
            return
        report.phase = 3
        table = self.table
        index = table.index
        addressed = np.zeros(len(table), dtype=bool)
        answered = np.zeros(len(table), dtype=bool)

        def mark(flags: np.ndarray, ids) -> None:
            for dxl_id in ids:
                pos = index.get(dxl_id)
                if pos is not None:  # an operation may have removed it meanwhile
                    flags[pos] = True

        for entry in report.reads:
            read, pending, _ = entry
            data = pending.result()
            if read.fast and self._fast_misses:
                for dxl_id in data:  # answered the fast read: a miss before was not its firmware
                    self._fast_misses.pop(dxl_id, None)
            if read.fast and len(data) < len(read.ids):
                data = self._read_plain(read, data)
            self.stats_reads += 1
            if len(data) == len(read.ids):
                self.stats_full_reads += 1
            entry[2] = data
            mark(addressed, read.ids)
            mark(answered, data)
        for dxl_id in report.recheck:
            mark(addressed, [dxl_id])
            if dxl_id in index and self.bus.ping(dxl_id, retries=0) is not None:
                mark(answered, [dxl_id])
        report.silent = [table.ids[pos] for pos in np.flatnonzero(addressed & ~answered)]
        self._update_ping(addressed, answered, report)
        report.read_s += time.perf_counter()

    def finish_step(self, report: StepReport) -> None:
        if report.phase >= 4:
            return
        self.complete_step(report)
        report.phase = 4
        for read, _, data in report.reads:
            if data:
                self._store(read, data, report.stamp, report.seq)
        if len(self.table):
            self._log_reads(report, report.silent)
        if "extra_dynamic" in report.groups:
            self._check_watchdogs = True  # at the next step, after this loop's states are out

    def _reconnect(self, report: StepReport) -> None:
        """The device vanished: servos on it read ping false; try to reopen it once a second."""
        dummies = self.bus.dummies
        if not self.device_lost:
            self.device_lost = True
            self.device_lost_since = time.time()
            self.log.error(f"{self.bus.device} is gone (the port hung up: unplugged, or another process reading it?): "
                           f"reconnecting every {RECONNECT_INTERVAL_S:g}s; states keep being published with ping false")
        for pos, dxl_id in enumerate(self.table.ids):
            if dxl_id not in dummies:
                self.table.ping[pos] = False
        report.groups.add("status")
        now = time.monotonic()
        if now < self._next_reconnect:
            return
        self._next_reconnect = now + RECONNECT_INTERVAL_S
        try:
            self.bus.reopen()
        except Exception as exc:  # BusError with the reason; anything else must not stop the loop
            self.log.debug(f"reconnect failed: {exc}")
            return
        self.device_lost = False
        self.device_lost_since = None
        self.reconnects += 1
        self.log.info(f"{self.bus.device} is back: reconnected (reconnect #{self.reconnects})")
        for dxl_id in list(self.table.ids):
            if dxl_id not in dummies and self.bus.ping(dxl_id, retries=1) is not None:
                self.table.ping[self.table.index[dxl_id]] = True
                self.arm_watchdog(dxl_id)

    def check_watchdogs(self) -> None:
        """Clear and re-arm watchdogs that tripped (the loop stalled longer than the watchdog
        time), whoever armed them: a tripped servo refuses goals until then."""
        for pos, dxl_id in enumerate(list(self.table.ids)):
            if self.table.known("bus_watchdog")[pos] and self.table.pulses("bus_watchdog")[pos] <= WATCHDOG_TRIPPED:
                self.watchdog_trips += 1
                pulses = self.watchdog_for(dxl_id)
                again = (f"watchdog re-armed ({self.table.model(dxl_id).bus_watchdog_ms_per_pulse * pulses:g} ms)"
                         if pulses else "watchdog cleared (off)")
                self.log.warning(f"ID {dxl_id}: bus watchdog tripped (no instruction within its time): "
                                 f"servo stopped, {again}")
                self.arm_watchdog(dxl_id)

    # ---------------------------------------------------------------- writes
    def _encode_pending(self) -> dict[tuple[int, int], dict[int, bytes]]:
        """The pending values as one sync write per item ``{(address, size): {id: bytes}}``; the
        table takes them."""
        pending = self.pending.take()
        if not pending or not len(self.table):
            return {}
        # (address, size) -> {item: {id: pulses}}: one sync write per item and layout
        writes: dict[tuple[int, int], dict[int, bytes]] = {}
        index = self.table.index
        for item, values in pending.items():
            positions, written = [], []
            for dxl_id, pulses in values.items():
                pos = index.get(dxl_id)
                if pos is None:
                    continue
                spec = self.table.models[pos].items.get(item)
                if spec is None:
                    continue
                try:
                    data = int(pulses).to_bytes(spec.size, "little", signed=spec.signed)
                except OverflowError:
                    self.log.error(f"ID {dxl_id}: {item}={pulses} does not fit its {spec.size} bytes: not written")
                    continue
                writes.setdefault((spec.address, spec.size), {})[dxl_id] = data
                positions.append(pos)
                written.append(pulses)
            if positions:
                self.table.store(item, np.asarray(positions), np.asarray(written, dtype=np.int64),
                                 self.table.read_time.get(item, 0.0))
                self.table.note_set(item, [self.table.ids[pos] for pos in positions])
        return writes

    # ---------------------------------------------------------------- reads
    def due_items(self, loop: int) -> tuple[list[str], set[str], set[str]]:
        cfg = self.config
        present_keys = {k for k in PRESENT if due(cfg.present_ratio(k), loop)}
        groups = {g for g, param in GROUP_RATIO_PARAM.items() if due(cfg[param], loop)}
        items: list[str] = [PRESENT[k][0] for k in PRESENT if k in present_keys]
        for g in groups:
            items += [i for i in GROUP_ITEMS[g] if i not in items]
        return items, present_keys, groups

    def _log_reads(self, report: StepReport, silent: list[int]) -> None:
        """verbose/read_<group>.{raw,err} and verbose/read_hardware_error, max_log_width IDs a line."""
        cfg, table = self.config, self.table
        groups = set(report.groups) | ({"present"} if report.present else set())
        for group in sorted(groups):
            key = "extra" if group.startswith("extra") else group
            if key == "error":
                continue
            if cfg.values.get(f"verbose/read_{key}.err") and silent:
                self.log.warning(f"read {group}: no answer from IDs {silent}")
            if cfg.values.get(f"verbose/read_{key}.raw"):
                items = ([PRESENT[k][0] for k in sorted(report.present)] if group == "present"
                         else list(GROUP_ITEMS[group]))
                for item in items:
                    if table.known(item).any():
                        self.log.info(f"read {group} {item}: " + _rows(table.ids, table.pulses(item), cfg["max_log_width"]))
        if "error" in report.groups and cfg["verbose/read_hardware_error"]:
            bits = np.where(table.known("hardware_error_status"), table.pulses("hardware_error_status"), 0)
            flags = units.decode_hardware_error(bits)
            for pos in np.flatnonzero(bits):
                dxl_id = table.ids[pos]
                if self._reported_errors.get(dxl_id) != bits[pos]:
                    causes = [name for name, f in flags.items() if f[pos]]
                    self.log.error(f"ID {dxl_id}: hardware error {', '.join(causes)} (0x{int(bits[pos]):02X}): "
                                   "clear it with the shortcut clear_error (CE)")
            self._reported_errors = {table.ids[pos]: bits[pos] for pos in np.flatnonzero(bits)}

    def _update_ping(self, addressed: np.ndarray, answered: np.ndarray, report: StepReport) -> None:
        table = self.table
        silent = addressed & ~answered
        back = answered & ~table.ping
        for pos in np.flatnonzero(silent & table.ping):
            self.log.warning(f"ID {table.ids[pos]}: no response (ping false)")
        for pos in np.flatnonzero(back):
            self.log.info(f"ID {table.ids[pos]}: answers again")
            # its bus watchdog may have tripped meanwhile (it then refuses goals): armed anew before
            # the next commands are written
            self._to_arm.add(table.ids[pos])
        # each read or ping of the servo that got no answer counts (a silent servo is only pinged
        # every RECHECK_LOOPS loops): the removal comes after no_response_id_auto_remove_count
        # unanswered requests in a row
        table.no_response[silent] += 1
        table.no_response[answered] = 0
        table.ping[silent] = False
        table.ping[answered] = True
        limit = self.config["no_response_id_auto_remove_count"]
        if limit > 0:
            for pos in reversed(np.flatnonzero(table.no_response >= limit)):
                dxl_id = table.ids[pos]
                self.log.warning(f"ID {dxl_id}: no response {limit} times in a row: removed "
                                 "(add it again with the shortcut add_id)")
                report.removed.append(dxl_id)
                self.remove_id(dxl_id)

    def _read_plain(self, read: _Read, data: dict[int, bytes]) -> dict[int, bytes]:
        """Read the servos a Fast Sync Read missed with a plain Sync Read.

        The servos answer a fast read in a chain, which stops at the first one that does not answer
        (silent, its segment garbled, or firmware without Fast Sync Read: old Pro "-R", early X and
        P); those after it were only cut off. So only that first one can lack the instruction: if it
        answers the plain read FAST_MISSES_PLAIN times in a row, it is read so from now on."""
        missing = [i for i in read.ids if i not in data]
        plain = self.bus.sync_read(read.address, read.length, missing)
        first = missing[0]
        if first in plain:
            self._fast_misses[first] = self._fast_misses.get(first, 0) + 1
            if self._fast_misses[first] >= FAST_MISSES_PLAIN:
                del self._fast_misses[first]
                self.log.info(f"ID {first}: no answer to Fast Sync Read, read with Sync Read from now on")
                self._plain_read.add(first)
                self._plans.clear()
        return {**data, **plain}

    def _plan(self, items: tuple[str, ...], live: np.ndarray) -> list[_Read]:
        """Sync reads for ``items`` over the live servos, grouped by control-table layout (cached)."""
        if self._plans_version != self.table.version:
            self._plans.clear()
            self._plans_version = self.table.version
        key = (items, live.tobytes())
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        layouts: dict[tuple, list[int]] = {}
        for pos, model in enumerate(self.table.models):
            if not live[pos]:
                continue
            sig = tuple((i, model.items[i].address, model.items[i].size, model.items[i].signed)
                        for i in items if model.has(i))
            fast = self.fast_read and self.table.ids[pos] not in self._plain_read
            if sig:
                layouts.setdefault((fast, tuple(sorted(sig, key=lambda s: s[1]))), []).append(pos)
        plan = []
        for (fast, sig), positions in layouts.items():
            ids = tuple(self.table.ids[p] for p in positions)
            for address, length, parts in _spans(sig, self.split_read):
                plan.append(_Read(address, length, ids, parts, fast))
        self._plans[key] = plan
        return plan

    def _store(self, read: _Read, data: dict[int, bytes], stamp: float, seq: int | None = None) -> None:
        """Store replies; values the host set after the read went out (sequence ``seq``) are newer and kept."""
        index = self.table.index
        ok_ids = [i for i in read.ids if i in data and i in index]  # an operation may have removed one meanwhile
        if not ok_ids:
            return
        positions = np.fromiter((index[i] for i in ok_ids), dtype=np.int64, count=len(ok_ids))
        buf = np.frombuffer(b"".join(data[i] for i in ok_ids), dtype=np.uint8).reshape(len(ok_ids), read.length)
        for part in read.parts:
            cols = buf[:, part.offset:part.offset + part.size].astype(np.int64)
            values = cols @ (np.int64(1) << (8 * np.arange(part.size, dtype=np.int64)))
            if part.signed:
                half = np.int64(1) << (8 * part.size - 1)
                values = np.where(values >= half, values - 2 * half, values)
            newer = self.table.newer_than(part.item, ok_ids, seq) if seq is not None else []
            if newer:
                keep = np.array([i not in newer for i in ok_ids])
                self.table.store(part.item, positions[keep], values[keep], stamp)
            else:
                self.table.store(part.item, positions, values, stamp)

    # ================================================================ shutdown
    def shutdown(self) -> None:
        """Leave the servos as term/* say. term/torque_auto_disable: torque off. Otherwise, with
        term/servo_auto_stop, every servo stops where it is and keeps holding: velocity, current
        and PWM goals := 0, goal position := present position, then torque off and on again on
        the servos whose torque is on (that also ends a profile move in progress). The bus
        watchdogs the handler armed are switched off (the goals that stop the servos are
        written)."""
        cfg = self.config
        if not self.bus.is_open:
            return
        ids = list(self.table.ids)
        stop = cfg["term/servo_auto_stop"]
        for dxl_id in ids:
            if stop:
                mode = self.mode(dxl_id)
                neutral = {"velocity": "goal_velocity", "current": "goal_current", "pwm": "goal_pwm"}.get(mode or "")
                if neutral:
                    self.write_item(dxl_id, neutral, 0)
            if cfg["term/torque_auto_disable"]:
                self.torque_off(dxl_id)
            elif stop:
                present = self.read_item(dxl_id, "present_position")
                if present is not None:
                    if self.mode(dxl_id) == "position":
                        present = self._clip_to_position_limits(dxl_id, present)
                    self.write_item(dxl_id, "goal_position", present)
                if self.read_item(dxl_id, "torque_enable") == 1:
                    self.write_item(dxl_id, "torque_enable", 0)
                    self.write_item(dxl_id, "torque_enable", 1)
            if (self.table.model(dxl_id).has("bus_watchdog") and dxl_id not in self.watchdog_user
                    and self.table.value("bus_watchdog", dxl_id)):
                self.write_item(dxl_id, "bus_watchdog", 0)


def _rows(ids: Sequence[int], values: np.ndarray, width: int) -> str:
    pairs = [f"{i}={v}" for i, v in zip(ids, values.tolist())]
    return "\n  ".join(", ".join(pairs[k:k + width]) for k in range(0, len(pairs), max(1, width)))


def _spans(sig: Sequence[tuple[str, int, int, bool]], split: bool) -> list[tuple[int, int, tuple[_Part, ...]]]:
    """Cut items (sorted by address) into read spans: one per item, or merged across small gaps."""
    spans: list[tuple[int, int, list[tuple[str, int, int, bool]]]] = []
    for item, address, size, signed in sig:
        if spans and not split and address - (spans[-1][0] + spans[-1][1]) <= SPAN_GAP:
            start, _, members = spans[-1]
            end = max(start + spans[-1][1], address + size)
            spans[-1] = (start, end - start, members + [(item, address, size, signed)])
        else:
            spans.append((address, size, [(item, address, size, signed)]))
    return [(start, length, tuple(_Part(i, a - start, s, sg) for i, a, s, sg in members))
            for start, length, members in spans]


def _merge_adjacent_writes(writes: dict[tuple[int, int], dict[int, bytes]]) -> dict[tuple[int, int], dict[int, bytes]]:
    """Join writes of back-to-back items that go to the same IDs into one sync write."""
    merged: dict[tuple[int, int], dict[int, bytes]] = {}
    last: tuple[int, int] | None = None
    for (address, size), data in sorted(writes.items()):
        if last is not None and last[0] + last[1] == address and set(merged[last]) == set(data):
            joined = {i: merged[last][i] + data[i] for i in data}
            del merged[last]
            last = (last[0], last[1] + size)
            merged[last] = joined
        else:
            last = (address, size)
            merged[last] = dict(data)
    return merged


def mode_value(name: str) -> int:
    return OPERATING_MODES[name]


__all__ = ["Handler", "Interrupted", "StartupError", "StepReport", "mode_value"]
