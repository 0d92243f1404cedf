"""Protocol 1.0 servos for the set-up tool: ping an ID and read its model number through the bus
(the Protocol 1.0 framer, ``protocol.protocol1``), name the model and know what it is from the
control table (``control_table.protocol1_models()``: the AX, RX, DX, EX and MX (1.0) models, and
the MX models whose Protocol 2.0 firmware exists). A broadcast ping gets no status in Protocol 1.0,
so every ID is pinged on its own. Also the rates a Protocol 1.0 servo can be reached at (its baud
table, as far as the bus opens them) and its mode, which the Angle Limits select."""
from __future__ import annotations

from functools import lru_cache

from ..bus import DYNAMIXEL_BAUDRATES, DynamixelBus, Failure
from ..bus.ops import Ping
from ..control_table import Model, known_models, model_by_number, protocol1_model_by_number, protocol1_models
from ..control_table._protocol1 import MODE_CODES, mode_of
from ..protocol import protocol1 as p1

__all__ = ["ping1", "model_name1", "switch_to_2", "protocol_of_type", "type_1_warning", "statuses1", "error_text1", "rates1",
           "mode1", "MODE_CODES", "error_names1"]


def protocol_of_type(raw: int) -> int:
    """The protocol a servo answers with Protocol Type ``raw`` (1: Protocol 1.0, else 2.0)."""
    return 1 if raw == 1 else 2


def type_1_warning(who: str, dxl_id: int) -> str:
    """What Protocol Type 1 means for a Protocol 2.0 servo (``set`` and ``restore`` warn the same)."""
    return (f"{who}: with protocol_type 1 it answers Protocol 1.0 only: the handler and Protocol 2.0 tools no "
            "longer find it (Protocol 1.0 has no sync read, and its one-byte address reaches only the first 256 "
            f"bytes of the table); this tool still reaches it, and `set {dxl_id} protocol_type 2` brings it back")


def model_name1(number: int) -> str:
    try:
        return protocol1_model_by_number(number).name
    except KeyError:
        return f"model {number}"


@lru_cache(maxsize=None)
def _twins() -> dict[int, str]:
    names = {m.name for m in known_models()}
    return {m.number: m.name for m in protocol1_models() if f"{m.name}(2.0)" in names}


def switch_to_2(number: int) -> str | None:
    """The name of the Protocol 1.0 model whose Protocol 2.0 firmware exists (``MX-28`` for model
    29: its 2.0 firmware makes it an MX-28(2.0)); None for the others."""
    return _twins().get(number)


def any_model(number: int) -> Model:
    """The model of a number, Protocol 2.0 or 1.0 (their numbers do not overlap); KeyError otherwise."""
    try:
        return model_by_number(number)
    except KeyError:
        return protocol1_model_by_number(number)


@lru_cache(maxsize=None)
def rates1() -> tuple[int, ...]:
    """The rates a Protocol 1.0 servo can be at that the bus opens (1 Mbps, 57,600 (value 34: 57,143
    bps, within the UART's tolerance), 115,200, 9,600, and 2 and 3 Mbps on MX)."""
    rates = {bps for m in protocol1_models() for bps in m.baud_rates.values()}
    return tuple(bps for bps in DYNAMIXEL_BAUDRATES if bps in rates)


def mode1(model: Model, cw_limit: int, ccw_limit: int, torque_control: int = 0) -> str:
    """The mode a Protocol 1.0 model is in by its Angle Limits (and Torque Control Mode Enable):
    a model without that mode (DX: no Wheel Mode; EX: no multi-turn) stays in Joint Mode."""
    mode = mode_of(cw_limit, ccw_limit, torque_control)
    return mode if mode in model.mode_values else "position"


def error_text1(error: int) -> str:
    """A Protocol 1.0 status error byte in words ("no error" when 0)."""
    return p1.error_text(error)


def error_names1(error: int) -> list[str]:
    """The error bits of a Protocol 1.0 status byte by name (``overload``, ``angle_limit`` ...)."""
    return [name.replace(" ", "_") for bit, name in enumerate(p1.ERROR_BITS) if error >> bit & 1]


def statuses1(data: bytes) -> list[tuple[int, int, bytes]]:
    """Every valid status packet in ``data`` as (ID, error byte, parameters); noise and packets
    with a wrong checksum are skipped."""
    return [(s.dxl_id, s.error, s.params) for s in p1.statuses(data)]


def ping1(bus: DynamixelBus, dxl_id: int, retries: int | None = 0) -> int | None:
    """The model number of a Protocol 1.0 servo at ``dxl_id``; None when none answers, 0 when it
    answers the ping but not the read of its model number (Status Return Level 0). Its firmware is
    an item of its model (``Servo.read("firmware_version")``): the ping cannot know where.
    ``retries`` None: as many as the bus is set to (``--retries``)."""
    got = bus.execute(Ping(dxl_id, retries=retries, protocol=1))
    if got.value is not None:
        return int(got.value)
    return 0 if got.failure is Failure.ANSWERS_PING_ONLY else None
