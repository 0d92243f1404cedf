"""The start-up scan: which servos answer at which IDs, in which protocol, and what the log says
about IDs two servos share and Protocol 1.0 servos whose family is off."""
from __future__ import annotations

import time
from typing import Callable, Sequence

from ..bus import ServoBus
from ..bus.census import census
from ..bus.ops import Ping
from ..control_table import PROTOCOL1_FAMILIES, Model, family_named, model_by_number
from ..errors import Interrupted, StartupError
from ..settings import ScanSettings
from .servo_io import Log

#: pause before each further scan: servos powered up with the computer get time to boot [s]
RETRY_PAUSE_S = 0.1
#: the pause is slept in steps of this, so that a signal ends the start-up at once [s]
_PAUSE_STEP_S = 0.02

#: what a user can do about a model number the control table does not know
UNKNOWN_MODEL_HELP = ("this version does not know that model (docs/models.md lists those it does); a newer "
                      "release may, otherwise report the number with the output of `dynamixel_handler_setup scan`")


def name_of(number: int) -> str:
    try:
        return model_by_number(number).name
    except KeyError:
        return f"model {number}"


def none_handled(found: dict[int, "Seen"], used: set[str]) -> None:
    """Servos answered, none is handled: why, as the start-up's end."""
    if not any(lookup(seen) is not None for seen in found.values()):
        raise StartupError(f"no servo of a known model among IDs {sorted(found)} (model numbers "
                           f"{sorted({n for _, n in found.values()})}): {UNKNOWN_MODEL_HELP}")
    raise StartupError(f"no servo of the used series ({'/'.join(sorted(used))}) among IDs "
                       f"{sorted(found)}: enable their series in init/used_servo_series")


#: a servo that answered the scan: (protocol, model number)
Seen = tuple[int, int]


def lookup(seen: Seen) -> Model | None:
    """The model of a servo that answered in ``seen``'s protocol with its model number (None: unknown)."""
    protocol, number = seen
    try:
        return model_by_number(number, protocol)
    except KeyError:
        return None



class Scan:
    """The scan of ``init/servo_auto_search`` with its retries, on one bus. ``problem``: what a
    start-up that cannot go on does (raise, or log and run on under ``debug``)."""

    def __init__(self, bus: ServoBus, log: Log, settings: ScanSettings, problem: Callable[[str], None],
                 interrupted: Callable[[], bool]) -> None:
        self.bus = bus
        self.log = log
        self.settings = settings
        self.problem = problem
        self.interrupted = interrupted
        self._told_shared: set[int] = set()  # IDs said to be shared (once each)

    def protocol1(self) -> bool:
        """Whether a Protocol 1.0 family is used (then Protocol 1.0 servos are looked for too)."""
        return any(family_named(s) in PROTOCOL1_FAMILIES for s in self.settings.used_series)

    def _enough(self, found: dict[int, Seen], dummies: Sequence[int], expected: int) -> bool:
        return len(self._usable(found, dummies)) >= expected if expected > 0 else len(found) >= 1

    def scan(self, dummies: Sequence[int], expected: int) -> dict[int, Seen]:
        """Scan init/servo_auto_search (retry_times more times until enough servos answer):
        {ID: (protocol, model number)}; Protocol 1.0 servos are pinged ID by ID where a Protocol
        1.0 family is used. Too few ends the start-up (``_startup_problem``)."""
        lo, hi = self.settings.min_id, self.settings.max_id
        attempts = self.settings.retry_times + 1
        found: dict[int, Seen] = {}
        protocol1 = self.protocol1()
        for attempt in range(attempts):
            if attempt:
                self._pause()
            if self.interrupted():
                raise Interrupted(f"start-up interrupted during the scan (attempt {attempt + 1}/{attempts})")
            self._scan_once(dummies, protocol1, found)
            real = sorted(set(found) - set(dummies))
            self.log.info(f"scan {attempt + 1}/{attempts} of IDs {lo}..{hi} on {self.bus.device} at "
                          f"{self.bus.baudrate} bps: {len(real)} servo(s) {real}"
                          + (f" + dummies {dummies}" if dummies else ""))
            if self._enough(found, dummies, expected) or not self.bus.is_open:
                break
        if not self._enough(found, dummies, expected):
            self._too_few(found, expected, protocol1)
        return found

    def _pause(self) -> None:
        """``RETRY_PAUSE_S`` between two scans, cut short by a signal."""
        end = time.monotonic() + RETRY_PAUSE_S
        while not self.interrupted() and (left := end - time.monotonic()) > 0:
            time.sleep(min(left, _PAUSE_STEP_S))

    def _scan_once(self, dummies: Sequence[int], protocol1: bool, found: dict[int, Seen]) -> None:
        """One scan of the IDs (Protocol 2.0, then Protocol 1.0 where used) into ``found``."""
        ids = range(self.settings.min_id, self.settings.max_id + 1)
        seen = census(self.bus, set(ids) | set(dummies), protocol=2)
        found.update({i: (2, n) for i, n in seen.found.items()})
        self._shared(seen.shared, found)
        if protocol1:  # a Protocol 2.0 servo ignores Protocol 1.0 packets: each ID is pinged in 1.0 too
            seen1 = census(self.bus, [i for i in ids if i not in seen.shared], protocol=1)
            for dxl_id in sorted(set(seen1.found) - set(seen.found)):  # a 2.0 reply late in the census?
                number = self.bus.execute(Ping(dxl_id, protocol=2)).value
                if number is not None:
                    seen.found[dxl_id] = number
                    found[dxl_id] = (2, number)
            found.update({i: (1, n) for i, n in seen1.found.items() if i not in found or found[i][0] == 1})
            self._shared({i: None for i in seen1.shared}, found)
            for dxl_id in sorted(set(seen1.found) & set(seen.found)):
                self._across(dxl_id, seen.found[dxl_id], seen1.found[dxl_id])

    def _too_few(self, found: dict[int, Seen], expected: int, protocol1: bool) -> None:
        lo, hi = self.settings.min_id, self.settings.max_id
        if not protocol1:
            self._explain_protocol1([i for i in range(lo, hi + 1) if i not in found])
        want = f"{expected}" if expected > 0 else "at least 1"
        self.problem(f"found {len(found)} servo(s) on {self.bus.device} at {self.bus.baudrate} bps, expected "
                              f"{want}: check power, wiring, IDs ({lo}..{hi}) and baudrate "
                              "(init/baudrate_auto_set can find servos at other rates)")

    def ping1(self, ids: Sequence[int]) -> dict[int, Seen]:
        """The Protocol 1.0 servos among ``ids`` (a Protocol 1.0 ping each: no broadcast answer)."""
        out: dict[int, Seen] = {}
        for dxl_id in ids:
            number = self.bus.execute(Ping(dxl_id, retries=0, protocol=1)).value
            if number is not None:
                out[dxl_id] = (1, number)
        return out

    def _explain_protocol1(self, ids: Sequence[int]) -> None:
        """Too few servos and no Protocol 1.0 family used: say which Protocol 1.0 servos answer."""
        by_family: dict[str, list[str]] = {}
        for dxl_id, (_, number) in self.ping1(ids).items():
            model = lookup((1, number))
            title = model.family.title if model is not None else "?"
            by_family.setdefault(title, []).append(f"ID {dxl_id} {model.name if model else f'model {number}'}")
        for title, servos in sorted(by_family.items()):
            self.log.warning(f"{', '.join(servos)}: answer(s) Protocol 1.0, family {title}, which "
                             f"init/used_servo_series does not enable: set init/used_servo_series.{title} true "
                             "to drive them")

    def _shared(self, shared: dict[int, int | None], found: dict[int, Seen]) -> None:
        """IDs two or more servos answer at: one line each, and not handled (a command to one would
        move all of them, and their replies garble every read)."""
        for dxl_id, number in sorted(shared.items()):
            found.pop(dxl_id, None)
            if dxl_id in self._told_shared:
                continue
            self._told_shared.add(dxl_id)
            which = f" (one of them a {name_of(number)})" if number is not None else ""
            self.log.error(f"ID {dxl_id}: two or more servos answer at this ID{which}, their replies collide: not "
                           "handled. Give each its own ID: connect them one at a time and run "
                           "`dynamixel_handler_setup assign-ids` (docs/setup_tool.md)")

    def _across(self, dxl_id: int, number2: int, number1: int) -> None:
        """A Protocol 1.0 servo at the ID of a Protocol 2.0 one: one line (once); the 2.0 servo is
        handled (the protocols do not collide), the 1.0 one is not."""
        if dxl_id in self._told_shared:
            return
        self._told_shared.add(dxl_id)
        one = lookup((1, number1))
        self.log.error(f"ID {dxl_id}: a {one.name if one else f'model {number1}'} answers Protocol 1.0 at the ID of "
                       f"the {name_of(number2)} (Protocol 2.0): two servos at one ID; the {name_of(number2)} is "
                       "handled, the Protocol 1.0 servo is not. Give each its own ID: connect them one at a time and "
                       "run `dynamixel_handler_setup assign-ids` (docs/setup_tool.md)")

    def _usable(self, found: dict[int, Seen], dummies: Sequence[int]) -> list[int]:
        """IDs among ``found`` that would be handled: known model of a used series, or a dummy."""
        used = set(self.settings.used_series)
        return [dxl_id for dxl_id, seen in found.items()
                if (model := lookup(seen)) is not None and (model.series in used or dxl_id in dummies)]

