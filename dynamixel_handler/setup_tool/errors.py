"""The tool's two kinds of failure: a step that failed (exit 1) and bad arguments (exit 2). Each
carries one line that names the servo and the cause."""
from __future__ import annotations

from ..logs import PATH_ECHO_MAX

__all__ = ["StepFailed", "BadArguments", "cut", "cut_path"]

#: characters of user input a message repeats
_ECHO = 40


def cut(text: object, limit: int = _ECHO) -> str:
    """User input as a message repeats it: one line, at most ``limit`` characters, the rest counted."""
    flat = str(text).replace("\n", " ").replace("\r", " ")
    return flat if len(flat) <= limit else f"{flat[:limit]}... ({len(flat)} characters)"


def cut_path(path: object) -> str:
    """A file path as a message names it: whole up to ``PATH_ECHO_MAX`` characters (a path cut
    short names no file)."""
    return cut(path, PATH_ECHO_MAX)


class StepFailed(Exception):
    """A step failed (no reply, refused write, read-back mismatch, busy port): exit code 1."""

    exit_code = 1


class BadArguments(StepFailed):
    """The command line asks for something impossible (unknown item, value out of range): exit code 2."""

    exit_code = 2
