"""A CDR message's sequence lengths read from their prefixes, before (and without) decoding it:
what a command subscription needs to refuse a message too large to be a command (``cdr.py`` has the
layout)."""
from __future__ import annotations

import struct

from .cdr import CDR_BE, CDR_LE, Codec


def sequence_counts(codec: Codec, data: bytes | bytearray | memoryview) -> dict[str, int]:
    """The element counts of a message's sequences, read from their length prefixes without
    decoding any element: fixed-size fields, strings and numeric sequences are skipped by their
    lengths, and the reading stops after the first sequence of strings (its strings would have to
    be walked). Nested fields are named 'a.b'. Whatever cannot be read (a truncated message, an
    unknown encapsulation) is left out."""
    out: dict[str, int] = {}
    kind = int.from_bytes(bytes(data[:2]), "big")
    if len(data) < 4 or kind not in (CDR_LE, CDR_BE):
        return out
    fmt = ("<" if kind == CDR_LE else ">") + "I"
    try:
        _counts(codec, memoryview(data), 4, fmt, "", out)
    except (struct.error, ValueError):
        pass
    return out


def _counts(codec: Codec, data: memoryview, pos: int, fmt: str, prefix: str, out: dict[str, int]) -> int:
    """``sequence_counts`` of one (nested) message from ``pos``; the position after it, -1 once stopped."""
    for name, kind, detail in codec.fields:
        if kind == "message":
            pos = _counts(detail, data, pos, fmt, f"{prefix}{name}.", out)
            if pos < 0:
                return pos
            continue
        if kind == "scalar":
            pos += -(pos - 4) % detail[1] + detail[1]
            continue
        pos += -(pos - 4) % 4
        (n,) = struct.unpack_from(fmt, data, pos)
        pos += 4
        if kind == "string":
            pos += n
        elif kind == "strings":
            out[prefix + name] = n
            return -1
        else:
            out[prefix + name] = n
            if n:
                pos += -(pos - 4) % detail[1] + n * detail[1]
    return pos
