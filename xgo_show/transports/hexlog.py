"""``hex+<url>`` (alias ``log+<url>``): log a transport's traffic as hex lines.

A wrapper, not a flag inside every transport (like pyserial's ``spy://`` and flockwave's
``serial+log:``). Each write and each non-empty read becomes one line::

    sim:mini > 55 00 09 02 07 0a e3 00 aa
    sim:mini < 55 00 12 12 07 4d 2d 31 2e 34 2e 31 00 00 00 68 00 aa

Lines go to ``stream`` if given, else to ``logger`` (default
``logging.getLogger("xgo_show.traffic")`` at DEBUG level).
"""

from __future__ import annotations

import logging
from typing import IO

from xgo_show.transports.base import Transport, WrappingTransport

__all__ = ["HexLogTransport"]

_DEFAULT_LOGGER = logging.getLogger("xgo_show.traffic")


class HexLogTransport(WrappingTransport):
    """Wraps ``inner`` and logs every byte written (``>``) and read (``<``) in hex.

    The class is itself the ``hex+`` wrapper factory of
    :func:`xgo_show.transports.open_transport`: ``HexLogTransport(inner, **options)``.
    """

    def __init__(
        self,
        inner: Transport,
        *,
        stream: IO[str] | None = None,
        logger: logging.Logger | None = None,
    ) -> None:
        super().__init__(inner, f"hex+{inner.url}")
        self._stream = stream
        self._logger = logger or _DEFAULT_LOGGER

    def write(self, data: bytes) -> None:
        self._log(">", data)
        self.inner.write(data)

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        data = self.inner.read(size, timeout)
        if data:
            self._log("<", data)
        return data

    def _log(self, direction: str, data: bytes) -> None:
        line = f"{self.inner.url} {direction} {data.hex(' ')}"
        if self._stream is not None:
            self._stream.write(line + "\n")
            self._stream.flush()
        else:
            self._logger.debug("%s", line)
