"""The one small interface every transport implements.

A transport is a byte pipe to one robot: open/close (also as a context manager), ``write`` bytes,
``read`` what has arrived within a timeout. Framing is not its job (see :mod:`xgo_show.wire`).
Transports are opened from URL strings by :func:`xgo_show.transports.open_transport`.
"""

from __future__ import annotations

import abc

from xgo_show.closing import Closing

__all__ = ["Transport", "WrappingTransport"]


class Transport(Closing, abc.ABC):
    """A byte link to one robot.

    ``write`` returns once the bytes are queued to the OS/device, not when they are on the wire.
    ``read`` returns up to ``size`` bytes, waiting at most ``timeout`` seconds for the first one
    (``0`` = only what is already there); it returns ``b""`` when nothing arrived.
    Failures raise :class:`xgo_show.errors.TransportError` naming the port and the reason.
    """

    url: str

    def __init__(self, url: str) -> None:
        self.url = url

    @abc.abstractmethod
    def open(self) -> None:
        """Open the link; raise TransportError naming the port and the reason on failure."""

    @abc.abstractmethod
    def close(self) -> None:
        """Close the link; safe to call more than once."""

    @property
    @abc.abstractmethod
    def is_open(self) -> bool:
        """Whether the link is open."""

    @abc.abstractmethod
    def write(self, data: bytes) -> None:
        """Queue ``data`` for sending."""

    @abc.abstractmethod
    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        """Return up to ``size`` received bytes, waiting at most ``timeout`` s for the first."""

    def set_low_latency(self) -> bool:
        """Ask the OS for low-latency mode (USB serial adapters); return whether it was granted."""
        return False

    def __enter__(self) -> Transport:
        if not self.is_open:
            self.open()
        return self


    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.url}>"


class WrappingTransport(Transport):
    """A transport around another one (traffic logging, test middleware).

    Opening, closing, ``is_open`` and low-latency mode are the inner link's; ``write`` and
    ``read`` pass through until a subclass overrides them.
    """

    def __init__(self, inner: Transport, url: str) -> None:
        super().__init__(url)
        self.inner = inner

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.inner.close()

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        return self.inner.read(size, timeout)

    def set_low_latency(self) -> bool:
        return self.inner.set_low_latency()
