"""Serial ports and every URL pyserial opens (``/dev/ttyUSB0``, ``COM3``, ``loop://``, …).

Errors from pyserial and the OS come back as :class:`~xgo_show.errors.TransportError` naming
the port and the reason (``cannot open /dev/ttyUSB9: No such file or directory``), raised
``from`` the original. Writes have a timeout so that a blocked port raises instead of hanging.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import re
import sys
import time
from typing import Any

import serial

from xgo_show.errors import TransportError, TransportTimeout
from xgo_show.fdwait import ReadableWaiter
from xgo_show.transports.base import Transport

__all__ = [
    "DEFAULT_WRITE_TIMEOUT",
    "SerialTransport",
    "describe_error",
    "open_serial",
    "write_now",
]

# Seconds between checks while waiting for input on ports with no file descriptor (loop://,
# socket://, rfc2217://, Windows).
_POLL_INTERVAL = 0.001

#: Seconds a write may block (output buffer full, flow control stuck) before it raises.
DEFAULT_WRITE_TIMEOUT = 1.0


def _gil_holding_write() -> Any:
    """libc's ``write`` called without releasing Python's lock, or None where unavailable."""
    if os.name != "posix":
        return None
    try:
        fn = ctypes.PyDLL(None, use_errno=True).write  # PyDLL: the call keeps the lock
        fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_size_t)
        fn.restype = ctypes.c_ssize_t
    except (OSError, AttributeError):
        return None
    return fn


_LIBC_WRITE = _gil_holding_write()


def write_now(fd: int, data: bytes) -> int:
    """``os.write`` on a non-blocking descriptor, keeping Python's lock through the call.

    os.write lets go of the lock for the system call, and a writer thread must win it back
    after: where several writers' frames fall due at once (one process, one grid), each such
    hand-over cost the next writer a thread wake-up, up to 0.1 ms on this 2-CPU VM (the
    runtime's IssueGroup writes them back to back; docs/realtime.md). A non-blocking write
    takes microseconds and never waits, so keeping the lock costs the other threads nothing.
    Raises BlockingIOError when the driver's buffer is full, OSError for any other failure.
    """
    if _LIBC_WRITE is None:
        return os.write(fd, data)
    sent = int(_LIBC_WRITE(fd, data, len(data)))
    if sent < 0:
        err = ctypes.get_errno()
        if err in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
            raise BlockingIOError(err, os.strerror(err))
        raise OSError(err, os.strerror(err))
    return sent


class SerialTransport(Transport):
    """A pyserial port opened with ``serial.serial_for_url(url, do_not_open=True)``.

    ``options`` are pyserial settings (``bytesize``, ``parity``, ``rtscts``, ``exclusive`` …);
    8N1 is pyserial's default and what every supported robot uses.
    """

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = 115200,
        write_timeout: float = DEFAULT_WRITE_TIMEOUT,
        **options: Any,
    ) -> None:
        super().__init__(url)
        self.baudrate = baudrate
        self.write_timeout = write_timeout
        self._options = options
        self._port: serial.SerialBase | None = None

    def open(self) -> None:
        if self._port is not None:
            return
        try:
            port = serial.serial_for_url(
                self.url,
                do_not_open=True,
                baudrate=self.baudrate,
                timeout=0,
                write_timeout=self.write_timeout,
                **self._options,
            )
            port.open()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TransportError(f"cannot open {self.url}: {describe_error(exc)}") from exc
        self._port = port

    def close(self) -> None:
        port, self._port = self._port, None
        if port is None:
            return
        with contextlib.suppress(serial.SerialException, OSError):
            port.close()  # if the device is already gone, closed is closed

    @property
    def is_open(self) -> bool:
        return self._port is not None

    def write(self, data: bytes) -> None:
        port = self._require_open()
        fd = self._fileno(port)
        if fd is not None:
            # The port is non-blocking: a frame that fits in the driver's buffer (every one,
            # unless the link is stuck) goes in one call. pyserial's write would then select()
            # on the port, and a tty's poll first waits for the kernel worker to move any
            # bytes received meanwhile: traced, a real-time writer slept up to 100 ms there
            # behind a normal-priority worker (docs/realtime.md).
            try:
                sent = write_now(fd, data)
            except BlockingIOError:
                sent = 0
            except OSError as exc:
                raise TransportError(f"write to {self.url} failed: {describe_error(exc)}") from exc
            if sent == len(data):
                return
            data = data[sent:]  # the rest waits for room, up to the write timeout
        try:
            port.write(data)
        except serial.SerialTimeoutException as exc:
            raise TransportTimeout(
                f"write to {self.url} blocked for more than {self.write_timeout:g} s"
            ) from exc
        except (serial.SerialException, OSError, ValueError) as exc:  # ValueError: fd past select()
            raise TransportError(f"write to {self.url} failed: {describe_error(exc)}") from exc

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        # The port stays non-blocking (pyserial timeout 0) and the wait happens here: changing
        # pyserial's timeout reconfigures the port, which for rfc2217:// is a network exchange.
        port = self._require_open()
        try:
            data: bytes = port.read(size)
            if data or timeout <= 0:
                return data
            deadline = time.monotonic() + timeout
            fd = self._fileno(port)
            while True:
                left = deadline - time.monotonic()
                if left <= 0:
                    return b""
                if fd is None:
                    time.sleep(min(left, _POLL_INTERVAL))
                else:
                    # Readable also when the device is gone: the read below then raises.
                    ReadableWaiter(fd).wait(left)
                data = port.read(size)
                if data:
                    return data
        except (serial.SerialException, OSError, ValueError) as exc:  # ValueError: fd past select()
            raise TransportError(f"read from {self.url} failed: {describe_error(exc)}") from exc

    @staticmethod
    def _fileno(port: serial.SerialBase) -> int | None:
        """A file descriptor to wait on (POSIX serial ports and ptys), else None."""
        if os.name != "posix" or not isinstance(port, serial.Serial):
            return None
        try:
            fd: int = port.fileno()
        except (AttributeError, OSError, serial.SerialException):
            return None
        return fd

    def set_low_latency(self) -> bool:
        """Ask the Linux serial driver for low latency (FTDI/CH340 adapters); never raises."""
        port = self._port
        if port is None or not sys.platform.startswith("linux"):
            return False
        setter = getattr(port, "set_low_latency_mode", None)
        if setter is None:
            return False
        try:
            setter(True)
        except (OSError, ValueError, serial.SerialException):
            return False  # ptys, sockets and some drivers do not support it
        return True

    def _require_open(self) -> serial.SerialBase:
        if self._port is None:
            raise TransportError(f"{self.url} is not open")
        return self._port


def open_serial(url: str, *, baudrate: int, **options: Any) -> SerialTransport:
    """Scheme factory for :func:`xgo_show.transports.open_transport`."""
    return SerialTransport(url, baudrate=baudrate, **options)


_PREFIX = re.compile(r"^(could not open port [^:]*: |could not configure port: )", re.IGNORECASE)


def describe_error(exc: BaseException) -> str:
    """The reason behind a pyserial/OS error, in words (``No such file or directory``)."""
    # pyserial's SerialException is an OSError subclass whose strerror is its whole message;
    # the OS error it wraps (cause/context) has the plain reason.
    for err in (exc.__cause__, exc.__context__, exc):
        if (
            isinstance(err, OSError)
            and not isinstance(err, serial.SerialException)
            and err.strerror
        ):
            return str(err.strerror)
    if exc.args and isinstance(exc.args[0], int) and exc.args[0] > 0:
        return os.strerror(exc.args[0])
    text = str(exc.args[-1] if exc.args else exc) or type(exc).__name__
    return _PREFIX.sub("", text)
