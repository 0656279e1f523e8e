"""Serial ports and every URL pyserial opens (``/dev/ttyUSB0``, ``COM3``, ``loop://``, …).

Errors from pyserial and the OS come back as :class:`~xgo_show.errors.TransportError` naming
the port and the reason (``cannot open /dev/ttyUSB9: No such file or directory``), raised
``from`` the original. Writes have a timeout so that a blocked port raises instead of hanging.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
from typing import Any

import serial

from xgo_show.errors import TransportError, TransportTimeout
from xgo_show.transports.base import Transport

__all__ = ["DEFAULT_WRITE_TIMEOUT", "SerialTransport", "describe_error", "open_serial"]

#: Seconds a write may block (output buffer full, flow control stuck) before it raises.
DEFAULT_WRITE_TIMEOUT = 1.0


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
        self._read_timeout: float | None = None

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
        self._read_timeout = 0.0

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
        try:
            port.write(data)
        except serial.SerialTimeoutException as exc:
            raise TransportTimeout(
                f"write to {self.url} blocked for more than {self.write_timeout:g} s"
            ) from exc
        except (serial.SerialException, OSError) as exc:
            raise TransportError(f"write to {self.url} failed: {describe_error(exc)}") from exc

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        port = self._require_open()
        try:
            if timeout != self._read_timeout:
                port.timeout = timeout  # reconfigures the port: only when it changes
                self._read_timeout = timeout
            first: bytes = port.read(1)
            if not first or size <= 1:
                return first
            waiting = port.in_waiting
            return first + (port.read(min(waiting, size - 1)) if waiting else b"")
        except (serial.SerialException, OSError) as exc:
            raise TransportError(f"read from {self.url} failed: {describe_error(exc)}") from exc

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
