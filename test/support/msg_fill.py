"""Fill every field of a generated message with distinct, deterministic values (and publish it).

Run as a script (`python msg_fill.py DxlStates /topic`) it publishes that message until killed, so
a test in another process can check that every field arrives unchanged.
"""
from __future__ import annotations

import importlib
import os
import sys

import numpy as np
from hypothesis import strategies as st

_SEQ = {
    "uint16": [1, 2, 65535], "int16": [-1, 4095, -32768], "double": [1.5, -2.25, 1e9],
    "boolean": [True, False, True], "string": ["position", "", "ex_position"],
}
_SCALAR = {"uint16": 7, "int16": -7, "double": 0.125, "boolean": True, "string": "torque_on",
           "int32": -123, "uint32": 456}


def nested_codecs(codec) -> list:
    """A ``cdr.Codec`` and the codecs of every sub-message in it, each once."""
    seen = {id(codec): codec}
    for _, kind, detail in codec.fields:
        if kind == "message":
            for inner in nested_codecs(detail):
                seen[id(inner)] = inner
    return list(seen.values())


def decoded_with(codec, raw: bytes, monkeypatch, patch) -> dict:
    """``codec.decode(raw)`` with ``patch(c)`` -> ``(attribute, value)`` set on the codec and every
    codec nested in it (a decoding shortcut switched off), for comparing with the shortcut on."""
    with monkeypatch.context() as m:
        for c in nested_codecs(codec):
            m.setattr(c, *patch(c))
        return codec.decode(raw)


def same_value(a, b) -> bool:
    """Decoded values equal: the same keys, arrays of the same dtype and values (NaN equal to NaN)."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return (isinstance(b, np.ndarray) and a.dtype == b.dtype
                and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    return a == b or (a != a and b != b)  # NaN


_INT = {"u1": (0, 255), "i1": (-128, 127), "u2": (0, 65535), "i2": (-32768, 32767),
        "u4": (0, 2**32 - 1), "i4": (-2**31, 2**31 - 1), "u8": (0, 2**64 - 1), "i8": (-2**63, 2**63 - 1)}


def _number(code: str, nan: bool = True) -> st.SearchStrategy:
    if code == "?":
        return st.booleans()
    if code[0] == "f":
        return st.floats(allow_nan=nan, width=32 if code == "f4" else 64)
    return st.integers(*_INT[code])


def _read_only(values: list, code: str) -> np.ndarray:
    arr = np.array(values, dtype=code)
    arr.setflags(write=False)
    return arr


def codec_values(codec, previous: dict | None = None, nan: bool = True) -> st.SearchStrategy:
    """A value of a ``cdr.Codec``'s message with every field optional (as state messages are when a
    loop reads only some groups); with ``previous``, each field may keep its value there (the very
    same object: a kept read-only array, a kept part) or get a new one: another length, a plain
    list, a read-only or writable array. ``nan``: floats may be NaN."""
    fields: dict[str, st.SearchStrategy] = {}
    for name, kind, detail in codec.fields:
        old = None if previous is None else previous.get(name)
        if kind == "message":
            new = codec_values(detail, old if isinstance(old, dict) else None, nan)
        elif kind == "array":
            code = detail[0]
            items = st.lists(_number(code, nan), max_size=4)
            new = st.one_of(items, items.map(lambda v, c=code: _read_only(v, c)),
                            items.map(lambda v, c=code: np.array(v, dtype=c)))
        elif kind == "strings":
            new = st.lists(st.text("abc", max_size=3), max_size=3)
        elif kind == "string":
            new = st.text("xyz", max_size=3)
        else:
            new = _number(detail[0], nan)
        fields[name] = st.one_of(st.just(old), new) if name in (previous or {}) else new
    return st.fixed_dictionaries({}, optional=fields)


def message_class(name: str):
    pkg, _, typ = name.rpartition("/") if "/" in name else ("dynamixel_handler_msgs/msg", "", name)
    module = importlib.import_module(pkg.replace("/", ".") if "." not in pkg else pkg)
    return getattr(module, typ)


def filled(cls, salt: int = 0):
    msg = cls()
    for i, (field, typ) in enumerate(msg.get_fields_and_field_types().items()):
        if typ.startswith("sequence<"):
            inner = typ[len("sequence<"):-1]
            values = list(_SEQ[inner])
            if inner in ("uint16", "int16"):
                values = [(v + salt + i) if abs(v) < 30000 else v for v in values]
            setattr(msg, field, values)
        elif typ in _SCALAR:
            setattr(msg, field, _SCALAR[typ])
        else:  # nested message, e.g. builtin_interfaces/Time or dynamixel_handler_msgs/DynamixelStatus
            pkg, typ_name = typ.split("/")
            nested = message_class(f"{pkg}/msg/{typ_name}")
            setattr(msg, field, filled(nested, salt + i + 1))
    return msg


def main() -> None:
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    import rclpy
    from rclpy.node import Node

    type_name, topic = sys.argv[1], sys.argv[2]
    cls = message_class(type_name)
    rclpy.init()
    node = Node("msg_fill_publisher")
    pub = node.create_publisher(cls, topic, 10)
    msg = filled(cls)
    node.create_timer(0.05, lambda: pub.publish(msg))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, Exception):
        pass


if __name__ == "__main__":
    main()
