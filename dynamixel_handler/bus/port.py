"""The serial port under the bus: open with clear errors, write, and wait for bytes without spinning.

The port is opened through ``dynamixel_sdk.PortHandler`` (its pyserial handle), but two of
its habits are replaced: it polls ``readPort`` in a tight loop (a CPU core at 100% while
waiting for a silent servo) and it hard-codes a 16 ms latency timer in its timeouts.
Here a read blocks in ``select()`` on the serial file descriptor until bytes arrive
or the deadline passes, and deadlines come from the configured latency timer.

Bytes go in and out with ``os.read``/``os.write`` on that (non-blocking) descriptor; the input
is counted with one ``ioctl`` before a wait, and once ``select()`` says bytes are in they are read
without counting them first: pyserial's ``read`` adds a ``select()`` and its ``write`` another to
every call, which at 4 Mbps is a good part of a transaction's host time. ``direct_io=False`` keeps
pyserial's calls (the same bytes).
"""
from __future__ import annotations

import errno
import fcntl
import os
import select
import sys
import termios
import time
from typing import Any, Callable

import serial
from dynamixel_sdk import PortHandler

from .errors import BusError
from .lock_holder import lock_holder

#: Baud rates Dynamixel servos can be set to (X, P and Pro series together).
DYNAMIXEL_BAUDRATES = (9600, 57600, 115200, 1000000, 2000000, 3000000, 4000000, 4500000,
                       6000000, 10500000)
#: rates of the Protocol 1.0 baud tables (2,000,000 / (v + 1), MX adds 2.25 and 2.5 Mbps) that no
#: Protocol 2.0 servo takes: a bus of AX, RX, DX, EX or MX (1.0) servos may run at them
PROTOCOL1_BAUDRATES = (200000, 250000, 400000, 500000, 2250000, 2500000)
#: every rate the bus opens a line at
LINE_BAUDRATES = tuple(sorted(DYNAMIXEL_BAUDRATES + PROTOCOL1_BAUDRATES))


#: a read that sleeps through the wire time of the bytes still expected wakes this much earlier [s]
SLEEP_SLACK_S = 0.0003

#: most bytes one read takes (a reply train of 30 servos is ~800 bytes; more waits for the next read)
_READ_MAX = 4096
_INT_ZERO = bytes(4)  # the ioctl's buffer for the input count (an unsigned int)
#: pyserial's text for a descriptor that is readable but gives no bytes, kept for the same log line
_NO_DATA = ("device reports readiness to read but returned no data "
            "(device disconnected or multiple access on port?)")


class _SdkPort(PortHandler):  # type: ignore[misc]  # dynamixel_sdk has no type information
    """PortHandler that locks the device, keeps one pyserial handle across baud changes,
    and accepts every Dynamixel baud rate (the SDK refuses e.g. 4.5 Mbps)."""

    # set by PortHandler
    port_name: str
    baudrate: int
    is_open: bool
    ser: Any  # serial.Serial (pyserial has no type information)
    tx_time_per_byte: float

    def getCFlagBaud(self, baudrate: int) -> int:  # noqa: N802 (SDK name)
        return baudrate if baudrate in LINE_BAUDRATES else -1

    def setupPort(self, cflag_baud: int) -> bool:  # noqa: N802 (SDK name)
        if self.is_open and self.ser is not None:
            self.ser.baudrate = self.baudrate
        else:
            self.ser = serial.Serial(port=self.port_name, baudrate=self.baudrate,
                                     bytesize=serial.EIGHTBITS, timeout=0, exclusive=True)
            self.is_open = True
            self.ser.reset_input_buffer()
        self.tx_time_per_byte = (1000.0 / self.baudrate) * 10.0
        return True


def explain_open_error(device: str, exc: BaseException) -> str:
    """One user-facing sentence for why ``device`` could not be opened, and what to do."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code in (errno.EACCES, errno.EPERM) or "ermission denied" in text:
        return (f"permission denied opening {device}: add your user to the 'dialout' group "
                f"(sudo usermod -aG dialout $USER, then log out and in) or install a udev rule for the adapter.")
    if code in (errno.EAGAIN, errno.EBUSY) or "exclusively lock" in text or "busy" in text.lower():
        return _busy(device)
    if code == errno.ENOTTY or "Inappropriate ioctl" in text or "configure port" in text:
        return f"{device} is not a serial port: point device_name at the adapter's tty (e.g. /dev/ttyUSB0)."
    if code == errno.ENOENT or "No such file" in text or not os.path.exists(device):
        return (f"{device} does not exist: is the adapter plugged in and powered? "
                f"Check `ls /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id/` and the device_name parameter.")
    return f"cannot open {device}: {text}"


def _busy(device: str) -> str:
    """Why ``device`` cannot be opened when another program holds its lock: who, and how to stop it."""
    holder = lock_holder(device)
    if holder is not None:
        pid, program = holder
        return (f"{device} is busy: {program or 'a program'} (pid {pid}) holds it. Stop it first "
                f"(Ctrl-C where it runs, or kill {pid}); only one program may use a bus at a time.")
    return (f"{device} is busy: another program holds it (a running dynamixel_handler, Dynamixel Wizard, a "
            f"serial console?). Close it; `fuser -v {device}` shows who.")


def _sysfs_latency_path(device: str) -> str | None:
    name = os.path.basename(os.path.realpath(device))
    path = f"/sys/bus/usb-serial/devices/{name}/latency_timer"
    return path if os.path.exists(path) else None


class SerialPort:
    """A Dynamixel serial line: exclusive open, raw bytes out, bytes in with a deadline."""

    def __init__(self, device: str, baudrate: int, latency_timer_ms: float,
                 log: Callable[[str, str], None] | None = None, direct_io: bool = True) -> None:
        self.device = device
        #: read and write with os.read/os.write on the descriptor (False: through pyserial)
        self.direct_io = direct_io
        self._fd = -1
        self.baudrate = baudrate
        self.latency_timer_ms = float(latency_timer_ms)
        #: latency actually in effect: the adapter's if we can read it and it is longer.
        self.effective_latency_ms = float(latency_timer_ms)
        self._log = log
        self._port: _SdkPort | None = None
        self.lost = False

    # -- lifecycle -----------------------------------------------------------------
    @property
    def is_open(self) -> bool:
        return self._port is not None and self._port.is_open and not self.lost

    @property
    def _sdk(self) -> _SdkPort:
        """The open port; AttributeError when closed (the I/O methods below are used on an open port)."""
        if self._port is None:
            raise AttributeError(f"{self.device} is closed")
        return self._port

    def open(self) -> None:
        check_baudrate(self.baudrate)
        if self.is_open:
            return
        self.close()
        if not os.path.exists(self.device):
            raise BusError(explain_open_error(self.device, FileNotFoundError(errno.ENOENT, "No such file")))
        port = _SdkPort(self.device)
        port.baudrate = self.baudrate
        try:
            port.openPort()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise BusError(explain_open_error(self.device, exc)) from exc
        self._port = port
        self._fd = port.ser.fileno()
        self.lost = False
        self._apply_latency_timer()

    def close(self) -> None:
        port, self._port = self._port, None
        self._fd = -1
        if port is not None and port.ser is not None:
            try:
                port.closePort()
            except (serial.SerialException, OSError):
                pass

    def set_baudrate(self, baudrate: int) -> None:
        check_baudrate(baudrate)
        self.baudrate = baudrate
        if self.is_open:
            try:
                self._sdk.setBaudRate(baudrate)
            except (serial.SerialException, OSError, ValueError) as exc:
                raise BusError(f"cannot set {self.device} to {baudrate} bps: {exc}") from exc

    def _apply_latency_timer(self) -> None:
        """Make the adapter's latency timer (FTDI sysfs knob) match the configured one when we can.

        If the adapter keeps a longer latency than configured, our reply timeouts would
        be shorter than the adapter's buffering, so we use the adapter's value and say so.
        """
        self.effective_latency_ms = self.latency_timer_ms
        path = _sysfs_latency_path(self.device)
        if path is None:
            return
        try:
            with open(path) as handle:
                actual = float(handle.read().strip())
        except (OSError, ValueError):
            return
        wanted = max(1, int(round(self.latency_timer_ms)))
        if actual != wanted:
            try:
                with open(path, "w") as handle:
                    handle.write(str(wanted))
                actual = float(wanted)
            except OSError:
                pass
        if actual > self.latency_timer_ms:
            self.effective_latency_ms = actual
            if self._log:
                self._log("warning",
                          f"{self.device}: adapter latency timer is {actual:g} ms but latency_timer is "
                          f"{self.latency_timer_ms:g} ms; using {actual:g} ms. To lower it: "
                          f"echo {wanted} | sudo tee {path}")

    # -- I/O ------------------------------------------------------------------------
    @property
    def tx_ms_per_byte(self) -> float:
        """Wire time of one byte (start + 8 data + stop bits)."""
        return 10_000.0 / self.baudrate

    def discard_input(self) -> int:
        """Drop whatever is waiting (late replies of earlier transactions); returns the count."""
        dropped = 0
        while True:
            waiting = self._in_waiting()
            if not waiting:
                return dropped
            dropped += len(self._read(waiting))

    def waiting(self) -> int:
        """Bytes in the input buffer now (0 if the port is closed or gone)."""
        try:
            return self._in_waiting() if self.is_open else 0
        except (OSError, serial.SerialException, AttributeError):
            return 0

    def _in_waiting(self) -> int:
        if self.direct_io:
            return int.from_bytes(fcntl.ioctl(self._fd, termios.TIOCINQ, _INT_ZERO), sys.byteorder)
        return int(self._sdk.ser.in_waiting)

    def _read(self, size: int) -> bytes:
        """Up to ``size`` bytes that are in already, never waiting (b"" if none). Raises
        SerialException, as pyserial does, if the device reports bytes it does not give."""
        if not self.direct_io:
            return bytes(self._sdk.readPort(size))
        try:
            data = os.read(self._fd, size)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise serial.SerialException(f"read failed: {exc}") from exc
        if not data:
            raise serial.SerialException(_NO_DATA)
        return data

    def write(self, packet: bytes) -> None:
        if not self.direct_io:
            written = self._sdk.writePort(packet)
            if written != len(packet):
                raise serial.SerialException(f"wrote {written} of {len(packet)} bytes")
            return
        rest = memoryview(packet)
        while rest:
            try:
                rest = rest[os.write(self._fd, rest):]
            except BlockingIOError:
                pass
            except OSError as exc:
                raise serial.SerialException(f"write failed: {exc}") from exc
            if rest:  # the driver's buffer is full: wait until it takes more
                select.select([], [self._fd], [], None)

    def read_until(self, deadline: float, expect: int = 0, due: float | None = None) -> bytes:
        """Bytes available now, or block (no spinning) until some arrive or ``deadline`` passes.

        ``expect``: bytes the caller still waits for. Once some have arrived, the rest of them
        cannot arrive sooner than their wire time, so the thread sleeps that long and reads them
        in one go instead of waking for every status packet. ``due``: when the last of them
        should be in (``time.monotonic()``); the sleep never runs past it, because bytes that are
        late (an adapter or a servo that buffers) come in a burst: past ``due`` the thread waits
        for the next bytes instead. Returns b"" at the deadline.
        Raises OSError/SerialException if the device vanished.
        """
        if self.direct_io:
            return self._read_direct(deadline, expect, due)
        waiting = self._in_waiting()
        if not waiting:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return b""
            readable, _, _ = select.select([self._sdk.ser.fileno()], [], [], remaining)
            if not readable:
                return b""
            waiting = self._in_waiting()
            if not waiting:
                data = self._read(1)
                if data:
                    return data
                # readable but empty: a hung-up device (pyserial raises on most systems)
                raise serial.SerialException(f"{self.device} hung up")
        if expect > waiting:
            # wake a little before the last byte is due (a sleep overshoots, the first bytes were
            # noticed late); the caller's next call catches the rest as it arrives
            rest_s = blind_sleep_s(expect - waiting, self.tx_ms_per_byte / 1000.0, time.monotonic(), due)
            if rest_s > 0:
                time.sleep(max(0.0, min(rest_s, deadline - time.monotonic())))
                waiting = max(waiting, self._in_waiting())
        return self._read(waiting)

    def _read_direct(self, deadline: float, expect: int, due: float | None) -> bytes:
        """``read_until`` on the descriptor itself: once ``select`` says bytes are in, they come
        with one ``read`` of up to ``_READ_MAX`` bytes, without asking for their count first (the
        same bytes, a system call less). The count before the wait stays: it is also how a
        hung-up device shows."""
        waiting = self._in_waiting()
        if waiting:
            data = self._read(waiting)
        else:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return b""
            readable, _, _ = select.select([self._fd], [], [], remaining)
            if not readable:
                return b""
            data = self._take()
            if not data:  # readable but empty: a hung-up device (the input count says how, as before)
                self._in_waiting()
                raise serial.SerialException(_NO_DATA)
        if expect > len(data):
            rest_s = blind_sleep_s(expect - len(data), self.tx_ms_per_byte / 1000.0, time.monotonic(), due)
            if rest_s > 0:
                time.sleep(max(0.0, min(rest_s, deadline - time.monotonic())))
                data += self._take()
        return data

    def _take(self) -> bytes:
        """What is in the input now, up to ``_READ_MAX`` bytes (b"" if nothing: the port reads
        without waiting, so an empty read is no hang-up here)."""
        try:
            return os.read(self._fd, _READ_MAX)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise serial.SerialException(f"read failed: {exc}") from exc


def blind_sleep_s(missing: int, byte_s: float, now: float, due: float | None = None) -> float:
    """How long a read that still misses ``missing`` bytes may sleep without looking at the port:
    until ``SLEEP_SLACK_S`` before their wire time is over, and never past ``SLEEP_SLACK_S`` before
    ``due`` (when they should all be in). <= 0: do not sleep, wait for the next bytes instead."""
    rest_s = missing * byte_s - SLEEP_SLACK_S
    if due is not None:
        rest_s = min(rest_s, due - SLEEP_SLACK_S - now)
    return rest_s


def check_baudrate(baudrate: int) -> None:
    if baudrate not in LINE_BAUDRATES:
        supported = ", ".join(str(b) for b in LINE_BAUDRATES)
        raise BusError(f"baudrate {baudrate} is not a Dynamixel baud rate: use one of {supported}.")
