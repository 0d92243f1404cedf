"""The pseudo-terminal the virtual bus is served on.

A host opens the slave side (``/dev/pts/N``, or a stable symlink such as ``/tmp/ttyDXL``)
exactly as it would open a USB serial adapter; the simulator reads and writes the master
side. The slave is put in raw mode so no byte is translated, and the simulator keeps its
own slave descriptor open so the master never reports EIO while hosts come and go.
"""

from __future__ import annotations

import array
import errno
import fcntl
import os
import termios
import time
import tty

# struct termios2 (asm-generic, x86 and arm): 4 flag words, c_line, 19 c_cc, then c_ispeed, c_ospeed.
# Unlike tcgetattr it reports custom rates (4.5M, 6M, 10.5M: BOTHER) as plain numbers.
_TCGETS2 = 0x802C542A
_TERMIOS2_OSPEED = 10
_BOTHER = 0o010000
_SPEED_OF = {getattr(termios, f"B{b}"): b for b in (
    9600, 19200, 38400, 57600, 115200, 230400, 460800, 500000, 576000, 921600, 1000000, 1152000,
    1500000, 2000000, 2500000, 3000000, 3500000, 4000000) if hasattr(termios, f"B{b}")}


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

    def host_baudrate(self) -> int | None:
        """The baud rate the host last set on its side of the line, or None if unknown.

        On Linux the termios ioctls of a pty master act on the slave, so the master sees the
        speed the host gave its serial port (pyserial sets 4.5M/6M/10.5M through TCSETS2 with
        BOTHER, which only TCGETS2 reads back as a number).
        """
        if self.master is None:
            return None
        buf = array.array("i", [0] * 64)
        try:
            fcntl.ioctl(self.master, _TCGETS2, buf)
            return int(buf[_TERMIOS2_OSPEED])
        except OSError:
            pass
        try:
            speed = termios.tcgetattr(self.master)[5]
        except termios.error:
            return None
        return None if speed == _BOTHER else _SPEED_OF.get(speed)

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
