"""CDR (XCDR1) encoding and decoding of the handler's own messages, straight to and from numpy.

rclpy turns every received message into Python objects field by field (a ``DxlCommandsX`` bundle
holds eleven sub-messages: ~150 µs even when one of them is used) and builds outgoing messages
through per-field property setters that check every element. The handler's messages are flat
arrays, so it reads the serialized bytes itself (``take_message(..., raw=True)``) and publishes
bytes it wrote itself (``Publisher.publish(bytes)``).

A ``Codec`` is built from the generated message class (field names and types from rosidl's
introspection), so it follows the .msg files. ``self_check()`` compares it with the middleware's
own serialization at start-up; the node uses it only when they agree and falls back to rclpy's
message objects otherwise (another RMW, another encoding), so correctness never depends on it.

Layout (OMG CDR v1, as Fast DDS and Cyclone DDS write ROS 2 messages): a 4-byte encapsulation
header (``00 01 00 00`` = little endian, ``00 00`` = big endian), then the fields in .msg order,
each primitive aligned to its size counted from the end of the header; a sequence is a uint32
count then the elements (no padding before elements when the count is 0); a string is a uint32
length including the terminating NUL, then the bytes and the NUL.
"""
from __future__ import annotations

import importlib
import struct
from typing import Any, Mapping

import numpy as np

HEADER_LE = b"\x00\x01\x00\x00"
#: encapsulation ids this module reads (big- and little-endian plain CDR)
CDR_BE, CDR_LE = 0x0000, 0x0001

#: rosidl primitive type name -> (numpy dtype code, size in bytes)
PRIMITIVES = {
    "boolean": ("?", 1), "octet": ("u1", 1), "char": ("u1", 1), "uint8": ("u1", 1), "int8": ("i1", 1),
    "uint16": ("u2", 2), "int16": ("i2", 2), "uint32": ("u4", 4), "int32": ("i4", 4),
    "uint64": ("u8", 8), "int64": ("i8", 8), "float": ("f4", 4), "double": ("f8", 8),
}


class Unsupported(TypeError):
    """A field type this codec does not handle (the node then uses rclpy's messages)."""


class DecodeError(ValueError):
    """The bytes do not hold a message of this type (truncated, or an unknown encapsulation)."""


def _message_class(type_name: str):
    pkg, _, name = type_name.partition("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


class Codec:
    """Encoder/decoder of one message type. Encoded values are nested dicts: a numeric sequence is
    anything numpy takes (decoded: a numpy array), a string sequence a list of str, a nested
    message a dict; missing fields encode as empty / zero / ""."""

    _cache: dict[type, "Codec"] = {}

    @classmethod
    def of(cls, msg_class) -> "Codec":
        codec = cls._cache.get(msg_class)
        if codec is None:
            codec = cls._cache[msg_class] = cls(msg_class)
        return codec

    def __init__(self, msg_class) -> None:
        self.msg_class = msg_class
        self.fields: list[tuple[str, str, Any]] = []  # (name, kind, detail)
        for name, typ in msg_class.get_fields_and_field_types().items():
            if typ.startswith("sequence<"):
                inner = typ[len("sequence<"):-1]
                if "," in inner:
                    raise Unsupported(f"{msg_class.__name__}.{name}: bounded sequence {typ}")
                if inner == "string":
                    self.fields.append((name, "strings", None))
                elif inner in PRIMITIVES:
                    self.fields.append((name, "array", PRIMITIVES[inner]))
                else:
                    raise Unsupported(f"{msg_class.__name__}.{name}: sequence of {inner}")
            elif typ == "string":
                self.fields.append((name, "string", None))
            elif typ in PRIMITIVES:
                self.fields.append((name, "scalar", PRIMITIVES[typ]))
            elif "/" in typ and "[" not in typ and "<" not in typ:
                self.fields.append((name, "message", Codec.of(_message_class(typ))))
            else:
                raise Unsupported(f"{msg_class.__name__}.{name}: {typ}")
        self._prepare()

    def _prepare(self) -> None:
        """What the encoder and decoder precompute from the fields."""
        #: (name, encoder, detail) per field, in .msg order
        self._puts = [(name, _PUT[kind], detail) for name, kind, detail in self.fields]
        #: the bytes of an all-empty value, by the offset's remainder modulo 8 (alignment is at most 8)
        self._empty: dict[int, bytes] = {}
        #: a message of sequences only (a command's part): its decoded value when every count is 0
        self._no_elements = _no_elements(self.fields)
        self._zero_counts = tuple(bytes(pad + 4 * len(self.fields)) for pad in range(4))
        #: any other message: its decoded value when its bytes are those of an empty value
        self._empty_value: dict[str, Any] | None = None

    # ------------------------------------------------------------------ encoding
    def encode(self, value: Mapping[str, Any]) -> bytes:
        out = bytearray(HEADER_LE)
        self._encode_into(out, value)
        out += b"\x00" * (-len(out) % 4)
        return bytes(out)

    def _encode_into(self, out: bytearray, value: Mapping[str, Any]) -> None:
        for name, put, detail in self._puts:
            put(out, value.get(name), detail)

    def _encode_empty(self, out: bytearray) -> None:
        """``_encode_into`` of an all-empty value (a group not read this loop), from a cache."""
        out += self._empty_at((len(out) - 4) % 8)

    def _empty_at(self, shift: int) -> bytes:
        """The bytes of an all-empty value that starts ``shift`` bytes past an 8-byte boundary."""
        raw = self._empty.get(shift)
        if raw is None:
            scratch = bytearray(4 + shift)
            self._encode_into(scratch, {})
            raw = self._empty[shift] = bytes(scratch[4 + shift:])
        return raw

    # ------------------------------------------------------------------ decoding
    def decode(self, data: bytes) -> dict[str, Any]:
        if len(data) < 4:
            raise DecodeError(f"{len(data)} bytes: no encapsulation header")
        kind = int.from_bytes(data[:2], "big")
        if kind not in (CDR_LE, CDR_BE):
            raise DecodeError(f"encapsulation 0x{kind:04x} is not plain CDR")
        try:
            value, _ = self._decode_from(memoryview(data), 4, "<" if kind == CDR_LE else ">")
        except (struct.error, ValueError, IndexError, UnicodeDecodeError) as exc:
            raise DecodeError(f"{self.msg_class.__name__}: {exc}") from None
        return value

    def _decode_from(self, data: memoryview, pos: int, order: str) -> tuple[dict[str, Any], int]:
        if self._no_elements is not None:  # most parts of a command bundle are empty: one compare
            zeros = self._zero_counts[-(pos - 4) % 4]
            if data[pos:pos + len(zeros)] == zeros:
                return dict(self._no_elements), pos + len(zeros)
        elif order == "<":  # other parts (strings, nested parts): the same bytes as an empty value's
            empty = self._empty_at((pos - 4) % 8)
            if data[pos:pos + len(empty)] == empty:
                if self._empty_value is None:
                    self._empty_value = self._decode_fields(memoryview(HEADER_LE + empty), 4, "<")[0]
                return _fresh(self._empty_value), pos + len(empty)
        return self._decode_fields(data, pos, order)

    def _decode_fields(self, data: memoryview, pos: int, order: str) -> tuple[dict[str, Any], int]:
        out: dict[str, Any] = {}
        count_fmt = order + "I"
        unpack_from = struct.unpack_from
        for name, kind, detail in self.fields:
            if kind == "array":
                code, size = detail
                pos += -(pos - 4) % 4
                (n,) = unpack_from(count_fmt, data, pos)
                pos += 4
                if n:
                    pos += -(pos - 4) % size
                    end = pos + n * size
                    if end > len(data):
                        raise ValueError(f"{name}: {n} elements run past the end")
                    out[name] = np.frombuffer(data, dtype=(order + code) if size > 1 else code, count=n, offset=pos)
                    pos = end
                else:
                    out[name] = _EMPTY[code]
            elif kind == "strings":
                pos += -(pos - 4) % 4
                (n,) = unpack_from(count_fmt, data, pos)
                pos += 4
                if n > len(data):
                    raise ValueError(f"{name}: {n} strings run past the end")
                items = []
                for _ in range(n):
                    s, pos = _get_string(data, pos, count_fmt)
                    items.append(s)
                out[name] = items
            elif kind == "message":
                out[name], pos = detail._decode_from(data, pos, order)
            elif kind == "string":
                out[name], pos = _get_string(data, pos, count_fmt)
            else:
                code, size = detail
                pos += -(pos - 4) % size
                (out[name],) = unpack_from(order + _STRUCT[code], data, pos)
                pos += size
        return out, pos

    # ------------------------------------------------------------------ rclpy objects
    def to_message(self, value: Mapping[str, Any]):
        """The same value as an rclpy message object (the fallback when raw bytes are not used)."""
        msg = self.msg_class()
        for name, kind, detail in self.fields:
            v = value.get(name)
            if v is None:
                continue
            if kind == "message":
                setattr(msg, name, detail.to_message(v))
            elif kind == "array":
                code = detail[0]
                arr = np.asarray(v)
                setattr(msg, name, arr.astype(bool).tolist() if code == "?" else
                        _to_array(arr, code) if code in _ARRAY_CODES else arr.tolist())
            elif kind == "strings":
                setattr(msg, name, list(v))
            else:
                setattr(msg, name, v)
        return msg

    def from_message(self, msg) -> dict[str, Any]:
        """An rclpy message object as the nested dict ``decode`` returns."""
        out: dict[str, Any] = {}
        for name, kind, detail in self.fields:
            v = getattr(msg, name)
            if kind == "message":
                out[name] = detail.from_message(v)
            elif kind == "array":
                out[name] = np.asarray(v, dtype=detail[0]) if len(v) else _EMPTY[detail[0]]
            elif kind == "strings":
                out[name] = list(v)
            else:
                out[name] = v
        return out


_STRUCT = {"?": "?", "u1": "B", "i1": "b", "u2": "H", "i2": "h", "u4": "I", "i4": "i", "u8": "Q", "i8": "q",
           "f4": "f", "f8": "d"}
_EMPTY = {code: np.empty(0, dtype=code) for code in _STRUCT}
for _arr in _EMPTY.values():
    _arr.flags.writeable = False
#: numpy dtype -> array.array typecode, for handing arrays to rclpy without per-element checks
_ARRAY_CODES = {"u2": "H", "i2": "h", "u4": "I", "i4": "i", "f4": "f", "f8": "d", "i8": "q", "u8": "Q"}


def _no_elements(fields: list[tuple[str, str, Any]]) -> dict[str, Any] | None:
    """The decoded value of a message of sequences only when all are empty; None for other messages."""
    if not fields or any(kind != "array" for _, kind, _ in fields):
        return None
    return {name: _EMPTY[detail[0]] for name, _, detail in fields}


def _fresh(value: dict[str, Any]) -> dict[str, Any]:
    """A copy of a decoded value whose dicts and lists are its own (arrays are read-only)."""
    return {k: _fresh(v) if type(v) is dict else list(v) if type(v) is list else v for k, v in value.items()}


def _to_array(arr: np.ndarray, code: str):
    import array
    out = array.array(_ARRAY_CODES[code])
    out.frombytes(np.ascontiguousarray(arr, dtype="=" + code).tobytes())
    return out


def _put_array(out: bytearray, v: Any, detail: tuple[str, int]) -> None:
    if v is None:
        out += _EMPTY_SEQ[len(out) % 4]
        return
    arr = v if type(v) is np.ndarray else np.asarray(v)
    n = arr.size
    if not n:
        out += _EMPTY_SEQ[len(out) % 4]
        return
    code, size = detail
    out += _ZEROS[-len(out) % 4]
    out += _COUNT.pack(n)
    out += _ZEROS[-(len(out) - 4) % size]
    out += arr.astype(_LE[code], copy=False).tobytes()


def _put_strings(out: bytearray, v: Any, _detail: None) -> None:
    items = () if v is None else v
    out += b"\x00" * (-(len(out) - 4) % 4)
    out += len(items).to_bytes(4, "little")
    for s in items:
        _put_string(out, s)


def _put_message(out: bytearray, v: Any, detail: Codec) -> None:
    if v is None:
        detail._encode_empty(out)
    else:
        detail._encode_into(out, v)


def _put_one_string(out: bytearray, v: Any, _detail: None) -> None:
    _put_string(out, "" if v is None else v)


def _put_scalar(out: bytearray, v: Any, detail: tuple[str, int]) -> None:
    code, size = detail
    out += b"\x00" * (-(len(out) - 4) % size)
    start = len(out)
    out += b"\x00" * size
    if code == "?":
        out[start] = 1 if v else 0
    elif v is not None:
        struct.pack_into("<" + _STRUCT[code], out, start, v)


#: offsets are counted from the end of the 4-byte header, so len(out) % 4 is the offset's remainder
_ZEROS = tuple(bytes(k) for k in range(8))
#: padding to 4 then a zero count, by len(out) % 4
_EMPTY_SEQ = tuple(bytes(-k % 4 + 4) for k in range(4))
_COUNT = struct.Struct("<I")
#: numpy dtype code -> little-endian dtype (booleans: one byte, 0 or 1)
_LE = {code: np.dtype(np.bool_) if code == "?" else np.dtype("<" + code) for code, _ in PRIMITIVES.values()}
#: field kind -> its encoder
_PUT: dict[str, Any] = {"array": _put_array, "strings": _put_strings, "message": _put_message,
                        "string": _put_one_string, "scalar": _put_scalar}


def _put_string(out: bytearray, s: str) -> None:
    raw = s.encode("utf-8")
    out += b"\x00" * (-(len(out) - 4) % 4)
    out += (len(raw) + 1).to_bytes(4, "little")
    out += raw
    out += b"\x00"


def _get_string(data: memoryview, pos: int, count_fmt: str) -> tuple[str, int]:
    pos += -(pos - 4) % 4
    (n,) = struct.unpack_from(count_fmt, data, pos)
    pos += 4
    if n == 0:  # some writers send an empty string as length 0
        return "", pos
    end = pos + n
    if end > len(data):
        raise ValueError(f"a string of {n} bytes runs past the end")
    raw = bytes(data[pos:end - 1])
    return raw.decode("utf-8"), end


def self_check(msg_classes) -> str | None:
    """None when this codec and the middleware agree on every message class, else the reason.

    Both directions are checked on a fully populated sample of each class: the middleware's
    bytes decoded here, and bytes encoded here read back by the middleware.
    """
    from rclpy.serialization import deserialize_message, serialize_message
    for msg_class in msg_classes:
        try:
            codec = Codec.of(msg_class)
            value = sample(codec)
            msg = codec.to_message(value)
            if not _same(codec.from_message(msg), codec.decode(serialize_message(msg))):
                return f"{msg_class.__name__}: the middleware's bytes decode differently here"
            if deserialize_message(codec.encode(value), msg_class) != msg:
                return f"{msg_class.__name__}: the middleware reads these bytes differently"
        except (Unsupported, DecodeError) as exc:
            return f"{msg_class.__name__}: {exc}"
    return None


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    return a == b


def sample(codec: Codec, n: int = 2) -> dict[str, Any]:
    """A value with every field populated (``n`` elements per sequence), for ``self_check``."""
    out: dict[str, Any] = {}
    for i, (name, kind, detail) in enumerate(codec.fields):
        if kind == "message":
            out[name] = sample(detail, n)
        elif kind == "array":
            code = detail[0]
            out[name] = (np.arange(n) % 2 == 0) if code == "?" else \
                np.arange(i + 1, i + 1 + n).astype(code) * (1.25 if code[0] == "f" else 1)
        elif kind == "strings":
            out[name] = [f"s{i}" * (k + 1) for k in range(n)]
        elif kind == "string":
            out[name] = f"str{i}"
        else:
            out[name] = (i % 2 == 0) if detail[0] == "?" else i + 1
    return out
