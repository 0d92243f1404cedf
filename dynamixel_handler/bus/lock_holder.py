"""Who holds a serial device: the process with the exclusive advisory lock (``flock``) on it.

A ``DynamixelBus`` opens its device with pyserial's ``exclusive=True``, which is
``flock(fd, LOCK_EX | LOCK_NB)`` on the descriptor: while a handler (or the set-up tool) runs, a
second opener fails at once instead of sharing the bus and reading half of another program's
replies. The kernel lists every flock in ``/proc/locks`` with the holder's pid and the locked
file's device and inode, which is what :func:`lock_holder` reads. ROS-free.
"""
from __future__ import annotations

import os

__all__ = ["lock_holder", "locks_readable", "program_of"]


def _locked_by(st_dev: int, st_ino: int, locks: str) -> int | None:
    """The pid holding a FLOCK on the file (device, inode) in the text of ``/proc/locks``."""
    wanted = f"{os.major(st_dev):02x}:{os.minor(st_dev):02x}:{st_ino}"
    for line in locks.splitlines():
        fields = line.split()
        # "1: FLOCK  ADVISORY  WRITE 12345 00:1a:6 0 EOF" (a blocked waiter's line has "->" in it)
        if len(fields) >= 6 and fields[1] == "FLOCK" and "->" not in fields[:2] and fields[5] == wanted:
            try:
                return int(fields[4])
            except ValueError:
                return None
    return None


def program_of(pid: int) -> str:
    """A short name of the program ``pid`` runs ("dynamixel_handler", "dynamixel_handler_setup"...)."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as handle:
            argv = [a.decode(errors="replace") for a in handle.read().split(b"\0") if a]
    except OSError:
        return ""
    for arg in argv:
        name = os.path.basename(arg)
        if not name.startswith("python") and not arg.startswith("-"):
            return name
    return os.path.basename(argv[0]) if argv else ""


def lock_holder(device: str, locks_file: str = "/proc/locks") -> tuple[int, str] | None:
    """(pid, program) of the process that holds the exclusive lock on ``device``; None when nobody
    does or it cannot be told (no ``/proc``, another pid namespace)."""
    try:
        st = os.stat(device)
        with open(locks_file, encoding="ascii", errors="replace") as handle:
            pid = _locked_by(st.st_dev, st.st_ino, handle.read())
    except OSError:
        return None
    if pid is None:
        return None
    return pid, program_of(pid)


def locks_readable(locks_file: str = "/proc/locks") -> bool:
    """Whether :func:`lock_holder` can tell that nobody holds a device (``/proc/locks`` is readable)."""
    return os.access(locks_file, os.R_OK)
