"""A streaming decoder over any one-frame parser: feed chunks, get complete frames out.

Both protocols have the same streaming problem (frames split across reads, junk between them)
and differ only in how one frame is recognised at the head of a buffer, which each codec's
``decode_one`` answers. Pure: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

__all__ = ["StreamDecoder"]

F = TypeVar("F")


class StreamDecoder(Generic[F]):
    """Feed it any chunks; it returns every complete frame, in order, and never raises.

    ``discarded`` counts bytes thrown away as junk (line noise, torn or corrupt frames),
    ``decoded`` the frames returned so far, ``pending`` the bytes held for an unfinished frame.
    """

    def __init__(self, decode_one: Callable[[bytearray], tuple[int, F | None]]) -> None:
        # decode_one(buffer) -> (bytes used, frame or None): 0 used = wait for more bytes;
        # bytes used with None = junk, dropped and counted.
        self._decode_one = decode_one
        self._buf = bytearray()
        self.discarded = 0
        self.decoded = 0

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)

    def feed(self, chunk: bytes | bytearray) -> list[F]:
        """Add bytes and return every complete frame they finish, in order."""
        self._buf += chunk
        out: list[F] = []
        while self._buf:
            used, frame = self._decode_one(self._buf)
            if used == 0:
                break
            del self._buf[:used]
            if frame is None:
                self.discarded += used
            else:
                self.decoded += 1
                out.append(frame)
        return out

    def reset(self) -> None:
        """Forget any partial frame (its bytes count as discarded); call before a request."""
        self.discarded += len(self._buf)
        self._buf.clear()
