"""Bring every servo of a bus to one baud rate. ROS-free.

Servos fresh from the box talk at 57600 bps, and a robot assembled from spares often has a
mix. :func:`unify_baudrate` finds them at every candidate rate, writes the target's Baud Rate
register value (an EEPROM item, so torque goes off first), then checks at the target rate that
each of them answers there. It only uses :class:`~dynamixel_handler.bus.DynamixelBus` and the
control tables, so the ``dynamixel_unify_baudrate`` tool and the handler's
``init/baudrate_auto_set`` share it.

Baud Rate register values (ROBOTIS e-Manual, "Baud Rate(8)"): 0..6 = 9600, 57600, 115200, 1M,
2M, 3M, 4M on every series; 7 = 4.5M except on X330 (which stops at 4M); P and PRO "-RA"
add 8 = 6M and 9 = 10.5M; the old PRO "-R" firmware has 8 = 10.5M and no 6M.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

from ..bus import DYNAMIXEL_BAUDRATES, BusError, DynamixelBus
from ..bus.ops import Ping, Read, Write
from ..control_table import Model, model_by_number

#: pings of a servo that the verification scan at the target missed, before it is called failed
VERIFY_PINGS = 3

#: Scan order: the usual rates first, 9600 (slow and rare) last.
SEARCH_ORDER = (57600, 115200, 1_000_000, 2_000_000, 3_000_000, 4_000_000, 4_500_000, 6_000_000,
                10_500_000, 9600)


def baud_register_values(model: Model) -> dict[int, int]:
    """``{bps: Baud Rate register value}`` for the rates ``model`` can use (its control table)."""
    return {bps: value for value, bps in model.baud_rates.items()}


def search_rates(min_bps: int, max_bps: int) -> list[int]:
    """The Dynamixel baud rates within ``[min_bps, max_bps]``, in scan order."""
    return [b for b in SEARCH_ORDER if min_bps <= b <= max_bps]


@dataclass
class ServoOutcome:
    """What happened to one servo."""

    dxl_id: int
    model_number: int
    model_name: str
    found_at: int                  # bps it answered at first
    state: str = "found"           # already | moved | failed
    reason: str = ""


@dataclass
class UnifyReport:
    """Result of :func:`unify_baudrate`; ``ok`` is what a tool's exit code should follow."""

    target: int
    searched: list[int] = field(default_factory=list)
    skipped_rates: dict[int, str] = field(default_factory=dict)  # rates the adapter refused
    servos: dict[int, ServoOutcome] = field(default_factory=dict)
    verified: dict[int, int] = field(default_factory=dict)       # id -> model number at the target
    error: str = ""                                              # a failure that stopped the run

    @property
    def already(self) -> list[int]:
        return [i for i, s in self.servos.items() if s.state == "already"]

    @property
    def moved(self) -> list[int]:
        return [i for i, s in self.servos.items() if s.state == "moved"]

    @property
    def failed(self) -> dict[int, str]:
        return {i: s.reason for i, s in self.servos.items() if s.state == "failed"}

    @property
    def ok(self) -> bool:
        """True when servos were found and every one of them now answers at the target rate."""
        return not self.error and bool(self.servos) and not self.failed

    def summary(self) -> list[str]:
        """Log lines: one overall line, then one per servo."""
        if self.error:
            head = f"baud rate unification to {self.target} bps failed: {self.error}"
        else:
            head = (f"baud rate unification to {self.target} bps: {len(self.servos)} servo(s) found, "
                    f"{len(self.already)} already at the target, {len(self.moved)} moved, "
                    f"{len(self.failed)} failed")
        lines = [head]
        for dxl_id, s in sorted(self.servos.items()):
            detail = {"already": "already there", "moved": f"moved from {s.found_at} bps"}.get(
                s.state, f"FAILED: {s.reason}")
            lines.append(f"  ID {dxl_id:3d} {s.model_name:<18} {detail}")
        return lines


def unify_baudrate(bus: DynamixelBus, target: int, ids: Iterable[int], search_rates: Sequence[int],
                   log: Any = None) -> UnifyReport:
    """Set every servo among ``ids`` found at one of ``search_rates`` to ``target`` bps.

    The bus must be open; it is left at ``target``. A servo is never moved onto an ID already
    answering at the target (two servos would then share a bus address). Returns a report;
    raises only ``ValueError`` for a ``target`` that is no Dynamixel baud rate.
    """
    if target not in DYNAMIXEL_BAUDRATES:
        raise ValueError(f"target baud rate {target} is not a Dynamixel baud rate: use one of "
                         f"{', '.join(map(str, DYNAMIXEL_BAUDRATES))}")
    log = log if log is not None else logging.getLogger("dynamixel_handler.baudrate")
    wanted = sorted(set(int(i) for i in ids))
    report = UnifyReport(target=target)
    if not _switch(bus, target, report, log):
        report.error = f"the adapter cannot use the target rate {target} bps ({report.skipped_rates[target]})"
        return report
    for dxl_id, number in bus.scan(wanted).items():
        report.servos[dxl_id] = _outcome(dxl_id, number, target, "already")
    report.searched.append(target)
    log.info(f"at {target} bps (target): {_listing(report.servos)}")
    _search(bus, target, wanted, search_rates, report, log)
    if not _switch(bus, target, report, log):
        report.error = f"could not return to {target} bps to verify"
        return report
    _verify(bus, report, log)
    if not report.servos:
        report.error = (f"no servo answered at any searched rate ({', '.join(map(str, report.searched))} bps) "
                        f"with an ID in {wanted[0]}..{wanted[-1]}" if wanted else "no IDs to search")
    return report


def _search(bus: DynamixelBus, target: int, ids: list[int], rates: Sequence[int], report: UnifyReport,
            log: Any) -> None:
    """Scan at each rate not searched yet and move the servos found there to ``target``."""
    for rate in rates:
        if rate == target or rate in report.searched or not _switch(bus, rate, report, log):
            continue
        report.searched.append(rate)
        found = bus.scan(ids)
        log.info(f"at {rate} bps: {_listing({i: _outcome(i, n, rate, '') for i, n in found.items()})}")
        for dxl_id, number in found.items():
            _move(bus, dxl_id, number, rate, target, report, log)


def _move(bus: DynamixelBus, dxl_id: int, number: int, rate: int, target: int, report: UnifyReport,
          log: Any) -> None:
    outcome = _outcome(dxl_id, number, rate, "failed")
    earlier = report.servos.get(dxl_id)
    if earlier is not None:
        outcome.reason = (f"ID {dxl_id} also answers at {earlier.found_at} bps: two servos share this ID; "
                          f"give one of them another ID first")
        log.error(f"ID {dxl_id} at {rate} bps not moved: {outcome.reason}")
        if earlier.state != "failed":
            earlier.state, earlier.reason = "failed", f"another servo with ID {dxl_id} answers at {rate} bps"
        report.servos[dxl_id] = outcome
        return
    report.servos[dxl_id] = outcome
    try:
        model = model_by_number(number)
    except KeyError:
        outcome.reason = f"unknown model number {number}: its Baud Rate register values are not known"
        log.error(f"ID {dxl_id} at {rate} bps not moved: {outcome.reason}")
        return
    values = baud_register_values(model)
    if target not in values:
        outcome.reason = f"{model.name} cannot use {target} bps (it supports {', '.join(map(str, sorted(values)))})"
        log.error(f"ID {dxl_id} not moved: {outcome.reason}")
        return
    item, torque = model.item("baud_rate"), model.item("torque_enable")
    state = bus.execute(Read(dxl_id, torque.address, torque.size, protocol=2))
    if state.value is None:
        outcome.reason = f"no reply reading Torque Enable at {rate} bps ({state.why})"
        log.error(f"ID {dxl_id} not moved: {outcome.reason}")
        return
    if state.value[0]:
        log.warning(f"ID {dxl_id} ({model.name}): torque off to change its baud rate (EEPROM)")
        off = bus.execute(Write(dxl_id, torque.address, bytes([0]), protocol=2))
        if not off:
            outcome.reason = f"torque off refused ({off.why})"
            log.error(f"ID {dxl_id} not moved: {outcome.reason}")
            return
    value = values[target]
    written = bus.execute(Write(dxl_id, item.address, value.to_bytes(item.size, "little"), protocol=2))
    if not written:
        # The servo may have switched before its reply got through; verification decides.
        log.warning(f"ID {dxl_id}: no acknowledgement of Baud Rate = {value} ({written.why}); "
                    f"checking at {target} bps")
    else:
        log.info(f"ID {dxl_id} ({model.name}): Baud Rate {rate} -> {target} bps (register value {value})")
    outcome.state = "moved"


def _verify(bus: DynamixelBus, report: UnifyReport, log: Any) -> None:
    expected = {i: s for i, s in report.servos.items() if s.state in ("already", "moved")}
    if not expected:
        return
    report.verified = bus.scan(sorted(expected))
    # a scan pings each ID once; a servo expected here is asked again before it is called failed
    for dxl_id in sorted(set(expected) - set(report.verified)):
        number = bus.execute(Ping(dxl_id, retries=VERIFY_PINGS - 1, protocol=2)).value
        if number is not None:
            report.verified[dxl_id] = number
    report.verified = dict(sorted(report.verified.items()))
    for dxl_id, s in expected.items():
        number = report.verified.get(dxl_id)
        if number is None:
            s.state = "failed"
            s.reason = f"does not answer at {report.target} bps after the change (was at {s.found_at} bps)"
        elif number != s.model_number:
            s.state = "failed"
            s.reason = f"a different model ({number}) answers at {report.target} bps with this ID"
    log.info(f"verification at {report.target} bps: {len(report.verified)} of {len(expected)} answer")


def _switch(bus: DynamixelBus, rate: int, report: UnifyReport, log: Any) -> bool:
    try:
        bus.set_baudrate(rate)
        return True
    except BusError as err:
        report.skipped_rates[rate] = str(err)
        log.warning(f"skipping {rate} bps: {err}")
        return False


def _outcome(dxl_id: int, number: int, rate: int, state: str) -> ServoOutcome:
    try:
        name = model_by_number(number).name
    except KeyError:
        name = f"model {number}"
    return ServoOutcome(dxl_id, number, name, rate, state)


def _listing(found: Mapping[int, ServoOutcome]) -> str:
    if not found:
        return "no servo"
    return ", ".join(f"ID {i} ({s.model_name})" for i, s in sorted(found.items()))


# ---------------------------------------------------------------------- tool parameters
#: name -> (type, default, description) of the dynamixel_unify_baudrate tool's parameters
TOOL_PARAMS: Mapping[str, tuple[type, Any, str]] = {
    "device_name": (str, "/dev/ttyUSB0", "serial device of the bus"),
    "target_baudrate": (int, 1_000_000, "baud rate every servo is set to [bps]"),
    "latency_timer": (int, 16, "USB adapter latency timer [ms], 1..255"),
    "min_id": (int, 0, "lowest ID searched"),
    "max_id": (int, 20, "highest ID searched"),
    "min_search_baudrate": (int, 9600, "lowest baud rate searched [bps]"),
    "max_search_baudrate": (int, 10_500_000, "highest baud rate searched [bps]"),
}


@dataclass(frozen=True)
class UnifySettings:
    """The dynamixel_unify_baudrate tool's parameters, typed (fields named as ``TOOL_PARAMS``)."""

    device_name: str
    target_baudrate: int
    latency_timer: int
    min_id: int
    max_id: int
    min_search_baudrate: int
    max_search_baudrate: int


def validate_tool_params(values: Mapping[str, Any]) -> UnifySettings:
    """Complete ``values`` with defaults and check them; ValueError with one clear sentence if bad."""
    out = UnifySettings(**{name: _typed(name, typ, values.get(name, default))
                           for name, (typ, default, _) in TOOL_PARAMS.items()})
    rates = ", ".join(map(str, DYNAMIXEL_BAUDRATES))
    if not out.device_name.strip():
        raise ValueError("parameter 'device_name' is empty: set it to the adapter, e.g. /dev/ttyUSB0")
    if out.target_baudrate not in DYNAMIXEL_BAUDRATES:
        raise ValueError(f"parameter 'target_baudrate' = {out.target_baudrate} is not a Dynamixel "
                         f"baud rate; use one of {rates}")
    if not 1 <= out.latency_timer <= 255:
        raise ValueError(f"parameter 'latency_timer' = {out.latency_timer} must be 1..255 ms")
    _check_ids(out)
    if not search_rates(out.min_search_baudrate, out.max_search_baudrate):
        raise ValueError(f"no Dynamixel baud rate lies within min_search_baudrate..max_search_baudrate = "
                         f"{out.min_search_baudrate}..{out.max_search_baudrate}; rates are {rates}")
    return out


def _typed(name: str, typ: type, value: Any) -> Any:
    """``value`` as the parameter's type (a whole float is taken as an int); ValueError if it is not."""
    if typ is int and isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, typ) or isinstance(value, bool):
        kind = "an integer" if typ is int else "a string"
        raise ValueError(f"parameter '{name}' must be {kind}, got {type(value).__name__} {value!r}")
    return value


def _check_ids(out: UnifySettings) -> None:
    for name, value in (("min_id", out.min_id), ("max_id", out.max_id)):
        if not 0 <= value <= 252:
            raise ValueError(f"parameter '{name}' = {value} must be a servo ID, 0..252")
    if out.max_id < out.min_id:
        raise ValueError(f"parameter 'max_id' = {out.max_id} is below 'min_id' = {out.min_id}")
