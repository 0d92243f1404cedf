"""A ``--params-file`` looked at before rcl reads it (rcl parses it inside ``rclpy.init``): its
size, its nesting and its number of keys and values are checked on the text, before any YAML
parser sees it, then it is read as YAML to name the line of a syntax error.

rcl's own parser takes time that grows with the square of the number of entries (100,000 integers
in one list: 6 s; 100,000 keys: 12 s; 2.5 million: minutes, while SIGINT is not seen), and a
Python YAML parser recurses once per level of nesting. The limits are far above any robot's file
(the shipped one has about 120 keys in 8 kB) and low enough that rcl reads a file within them in
well under a second.
"""
from __future__ import annotations

import os
import re
import stat

from ..logs import cut_path

#: largest params file read [bytes]
MAX_BYTES = 1 << 20
#: deepest nesting of mappings and lists (the shipped file nests 3 deep)
MAX_DEPTH = 32
#: most keys, list entries and flow entries in one file
MAX_ENTRIES = 20_000
#: the most over all the files given (rcl reads each file given, the same one twice too): a set of
#: files within these starts in a second or two, and SIGINT is never held off longer than that
MAX_TOTAL_BYTES = 2 * MAX_BYTES
MAX_TOTAL_ENTRIES = 2 * MAX_ENTRIES

#: the characters that may start or end a YAML structure (everything else is scalar text)
_SPECIAL = re.compile(r"""[\[\]{},:#'"|>*&!\-?]""")
#: the rest of an anchor (&name) or a tag (!name)
_PROPERTY = re.compile(r"\S*")


class _Scan:
    """A cheap pass over the text: nesting depth and number of entries, with the line where a
    limit is passed. It follows YAML's lexical rules far enough to count (quoted scalars, comments,
    block scalars, flow collections) and errs on the side of counting more."""

    def __init__(self) -> None:
        self.entries = 0
        self.stack: list[int] = []  # indentation of the enclosing block lines
        self.flow = 0  # open [ and {
        self.quote = ""  # the quote of a quoted scalar still open at the end of a line
        self.block_parent: int | None = None  # inside a | or > block scalar: its parent's indentation
        self.peak = 0  # the deepest nesting of the line being scanned
        self.at_start = True  # where a scalar (or a collection) may start
        self.indent = 0
        self.alias = False
        self.problem = ""
        self._on = {"[": self._open, "{": self._open, "]": self._close, "}": self._close, ",": self._comma,
                    ":": self._colon, "#": self._hash, "'": self._quote, '"': self._quote, "|": self._block,
                    ">": self._block, "*": self._alias, "&": self._property, "!": self._property,
                    "-": self._indicator, "?": self._indicator}

    def line(self, text: str, number: int) -> None:
        body = text.lstrip(" ")
        self.indent = len(text) - len(body)
        if self.block_parent is not None:
            if not body.strip() or self.indent > self.block_parent:
                return  # text of a block scalar
            self.block_parent = None
        start = 0
        if not self.quote and not self.flow:
            if not body.strip() or body.startswith(("#", "---", "...", "%")):
                return
            while self.stack and self.stack[-1] >= self.indent:
                self.stack.pop()
            self.stack.append(self.indent)
            start = self._dashes(text, self.indent)
        self.peak = len(self.stack) + self.flow
        self._chars(text, start)
        self._limits(number)

    def _dashes(self, text: str, start: int) -> int:
        """Past the block list entries that start the line ("- - x": one nested in the other)."""
        while text.startswith(("- ", "-\t"), start) or text[start:].rstrip() == "-":
            self.entries += 1
            start += 1
            while text.startswith((" ", "\t"), start):
                start += 1
            if text.startswith("-", start):
                self.stack.append(start)
        return start

    def _chars(self, text: str, k: int) -> None:
        self.at_start = True
        while 0 <= k < len(text):
            if self.quote:
                k = self._quoted(text, k)
                self.at_start = False
                continue
            match = _SPECIAL.search(text, k)
            if match is None:
                return
            if text[k:match.start()].strip():
                self.at_start = False
            k = self._on[match.group()](text, match.end())  # -1: the rest of the line is no structure

    def _open(self, text: str, k: int) -> int:
        if self.at_start or self.flow:
            self.flow += 1
            self.entries += 1
            self.peak = max(self.peak, len(self.stack) + self.flow)
        else:
            self.at_start = False
        return k

    def _close(self, text: str, k: int) -> int:
        self.flow = max(0, self.flow - 1)
        self.at_start = False
        return k

    def _comma(self, text: str, k: int) -> int:
        if self.flow:
            self.entries += 1
        self.at_start = bool(self.flow)
        return k

    def _colon(self, text: str, k: int) -> int:
        if k == len(text) or text[k] in " \t" or (self.flow and text[k] in ",]}"):
            self.entries += 1  # a key
            self.at_start = True
        else:
            self.at_start = False
        return k

    def _hash(self, text: str, k: int) -> int:
        if k == 1 or text[k - 2] in " \t":
            return -1  # a comment
        self.at_start = False
        return k

    def _quote(self, text: str, k: int) -> int:
        if self.at_start:
            self.quote = text[k - 1]
        self.at_start = False
        return k

    def _block(self, text: str, k: int) -> int:
        if self.at_start and not self.flow:
            self.block_parent = self.indent
            return -1
        self.at_start = False
        return k

    def _alias(self, text: str, k: int) -> int:
        self.alias = self.alias or self.at_start
        self.at_start = False
        return k

    def _property(self, text: str, k: int) -> int:
        """An anchor (&name) or a tag (!name): the node follows it."""
        if self.at_start:
            return _PROPERTY.match(text, k).end()  # type: ignore[union-attr]
        return k

    def _indicator(self, text: str, k: int) -> int:
        """``-`` or ``?`` followed by a space keeps the place of a scalar's start."""
        if not (self.at_start and (k == len(text) or text[k] in " \t")):
            self.at_start = False
        return k

    def _quoted(self, text: str, k: int) -> int:
        """The index after the closing quote on this line (the scalar goes on when there is none)."""
        while True:
            end = text.find(self.quote, k)
            if end < 0:
                return len(text)
            if self.quote == '"':
                backslashes = len(text[k:end]) - len(text[k:end].rstrip("\\"))
                if backslashes % 2:  # an escaped quote
                    k = end + 1
                    continue
            elif text.startswith("''", end):  # '' is a quote in a single-quoted scalar
                k = end + 2
                continue
            self.quote = ""
            return end + 1

    def _limits(self, number: int) -> None:
        if self.peak > MAX_DEPTH:
            self.problem = f"nests deeper than {MAX_DEPTH} levels at line {number}"
        elif self.entries > MAX_ENTRIES:
            self.problem = f"more than {MAX_ENTRIES:,} keys and list entries (line {number})"
        elif self.alias:
            self.problem = f"a YAML alias (*name) at line {number}: ROS does not read aliases"


def scan_problem(text: str) -> str | None:
    """Why ``text`` is refused before it is parsed (too deep, too many entries, an alias), or None."""
    scan = _Scan()
    for number, line in enumerate(text.split("\n"), 1):
        scan.line(line.rstrip("\r"), number)  # CRLF line ends too
        if scan.problem:
            return scan.problem
    return None


class Totals:
    """What the params files given so far add up to; ``add`` says when the sum passes a limit."""

    def __init__(self) -> None:
        self.files = 0
        self.bytes = 0
        self.entries = 0

    def add(self, text: str) -> str | None:
        self.files += 1
        self.bytes += len(text.encode("utf-8"))
        scan = _Scan()
        for number, line in enumerate(text.split("\n"), 1):
            scan.line(line.rstrip("\r"), number)
        self.entries += scan.entries
        if self.bytes > MAX_TOTAL_BYTES or self.entries > MAX_TOTAL_ENTRIES:
            return (f"the {self.files} params files given add up to {self.bytes:,} bytes and {self.entries:,} keys and "
                    f"list entries, more than the {MAX_TOTAL_BYTES:,} bytes and {MAX_TOTAL_ENTRIES:,} entries all files "
                    "together may have (rcl reads each file given, the same one twice too): refused before parsing them")
        return None


def read_problem(path: str) -> tuple[str | None, str]:
    """(why the file is refused before any parsing, or None; its text)."""
    name = f"params file {cut_path(path)}"
    try:
        info = os.stat(path)
        if stat.S_ISDIR(info.st_mode):
            return f"{name}: cannot read it: it is a folder", ""
        if not stat.S_ISREG(info.st_mode):
            return f"{name}: not a regular file (a pipe or a device): ROS reads a params file as a file", ""
        if info.st_size > MAX_BYTES:
            return (f"{name}: {info.st_size:,} bytes, more than the {MAX_BYTES:,} a params file may have: "
                    "refused before reading it"), ""
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as err:
        return f"{name}: cannot read it: {err.strerror}", ""
    if len(data) > MAX_BYTES:  # it grew since
        return f"{name}: more than the {MAX_BYTES:,} bytes a params file may have: refused before reading it", ""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        return f"{name}: not text ({err.reason} at byte {err.start})", ""
    problem = scan_problem(text)
    if problem is not None:
        return f"{name}: {problem}: refused before parsing it", ""
    return None, text


__all__ = ["MAX_BYTES", "MAX_DEPTH", "MAX_ENTRIES", "MAX_TOTAL_BYTES", "MAX_TOTAL_ENTRIES", "Totals", "read_problem",
           "scan_problem"]
