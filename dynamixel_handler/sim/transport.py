"""The pseudo-terminal the virtual bus is served on.

A host opens the slave side (``/dev/pts/N``, or a stable symlink such as ``/tmp/ttyDXL``)
exactly as it would open a USB serial adapter; the simulator reads and writes the master
side. The slave is put in raw mode so no byte is translated, and the simulator keeps its
own slave descriptor open so the master never reports EIO while hosts come and go.
"""

from __future__ import annotations

import errno
import fcntl
import os
import time
import tty


class PtyPort:
    """Owns one pty pair and, optionally, a symlink pointing at its slave."""

    def __init__(self, link: str | None = None) -> None:
        self.link = link
        self.master: int | None = None
        self._slave: int | None = None
        self.slave_name: str | None = None

    @property
    def is_open(self) -> bool:
        return self.master is not None

    @property
    def path(self) -> str | None:
        """What a host should open: the symlink if any, else the slave device."""
        if self.master is None:
            return None
        return self.link or self.slave_name

    def open(self) -> str:
        master, slave = os.openpty()
        tty.setraw(slave)
        flags = fcntl.fcntl(master, fcntl.F_GETFL)
        fcntl.fcntl(master, fcntl.F_SETFL, flags | os.O_NONBLOCK)
        self.master, self._slave = master, slave
        self.slave_name = os.ttyname(slave)
        if self.link:
            tmp = f"{self.link}.{os.getpid()}.tmp"
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass
            os.symlink(self.slave_name, tmp)
            os.replace(tmp, self.link)  # atomic repoint, also over a stale link
        return self.path  # type: ignore[return-value]

    def close(self) -> None:
        """Unplug: close both descriptors (hosts then get I/O errors) and drop the link."""
        for fd in (self.master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self.master = self._slave = None
        if self.link and os.path.islink(self.link):
            try:
                if os.readlink(self.link) == self.slave_name:
                    os.unlink(self.link)
            except OSError:
                pass

    def read(self) -> bytes:
        if self.master is None:
            return b""
        try:
            return os.read(self.master, 4096)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:
                return b""
            raise

    def write(self, data: bytes) -> int:
        """Write what the line buffer takes; a host that does not read loses the rest."""
        if self.master is None or not data:
            return 0
        written = 0
        deadline = time.monotonic() + 0.05
        while written < len(data):
            try:
                written += os.write(self.master, data[written:])
            except BlockingIOError:
                if time.monotonic() > deadline:
                    break
                time.sleep(0.0005)
            except OSError:
                break
        return written


def wait_until(deadline: float, clock=time.perf_counter) -> None:
    """Sleep until ``deadline`` (perf_counter seconds), spinning only the last ~0.2 ms."""
    while True:
        remaining = deadline - clock()
        if remaining <= 0:
            return
        if remaining > 0.0003:
            time.sleep(remaining - 0.0002)
        # short spin for precision
