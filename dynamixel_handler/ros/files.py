"""Files the node writes on an owner's request (the servos snapshot, the joint calibration): the
path checked first, the text written atomically."""
from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from ..logs import cut_path

#: what a file of a kind other than a regular one is called in a refusal
_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def refusal(path: Path, device: str) -> str:
    """Why ``path`` is no file to write the snapshot to ("" when it is: a regular file, or none yet
    in an existing folder). Symbolic links are not followed."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return "" if path.parent.is_dir() else f"its folder {cut_path(path.parent)} does not exist"
    except OSError as exc:
        return f"cannot be looked at ({exc.strerror})"
    if stat.S_ISLNK(info.st_mode):
        return "is a symbolic link, which is not followed: give the path of the file itself"
    if device and os.path.realpath(path) == os.path.realpath(device):
        return "is the bus's own device"
    for test, kind in _KINDS:
        if test(info.st_mode):
            return f"is {kind}, not a regular file"
    return "" if stat.S_ISREG(info.st_mode) else "is not a regular file"


def write_atomically(path: Path, text: str) -> None:
    """``text`` to a temporary file next to ``path``, then renamed over it (the old file's
    permissions kept; a new one 0644)."""
    try:
        mode = stat.S_IMODE(os.lstat(path).st_mode)
    except FileNotFoundError:
        mode = 0o644
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:64]}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)  # replaces a link or file of that name, never writes through a link
    except BaseException:
        os.unlink(tmp)
        raise


__all__ = ["refusal", "write_atomically"]
