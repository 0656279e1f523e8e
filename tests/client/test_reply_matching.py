"""Property: whatever unsolicited frames and noise surround it, and however the link chunks
the bytes, a read returns exactly the reply to it.

The XGO protocol has no sequence numbers: a reply frame at the requested address with the
requested size *is* the reply. So the unsolicited frames here are at other addresses (0x07 and
0x01 are the ones read) or of another size.
"""

from __future__ import annotations

from collections import deque

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.client import XgoClient
from xgo_show.profiles import get_profile
from xgo_show.transports import open_transport
from xgo_show.transports.base import Transport, WrappingTransport
from xgo_show.wire.xgo import reply_frame


class NoisyLink(WrappingTransport):
    """Middleware for tests (like pymodbus' manipulator hook): after each write, the bytes the
    wrapped link answers are preceded by ``noise`` and handed out in ``chunks``-sized pieces."""

    def __init__(self, inner: Transport, noise: bytes, chunks: list[int]) -> None:
        super().__init__(inner, f"noisy+{inner.url}")
        self.noise = noise
        self.chunks = chunks
        self._out: deque[int] = deque()
        self._cut = 0

    def write(self, data: bytes) -> None:
        self.inner.write(data)
        self._out.extend(self.noise)

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        self._out.extend(self.inner.read(4096, timeout=0 if self._out else timeout))
        want = min(size, self.chunks[self._cut % len(self.chunks)])
        self._cut += 1
        return bytes(self._out.popleft() for _ in range(min(want, len(self._out))))


_other_replies = st.lists(
    st.tuples(
        st.integers(0x00, 0xFF).filter(lambda a: a not in (0x01, 0x07)),
        st.binary(min_size=1, max_size=24),
    ).map(lambda t: reply_frame(*t)),
    max_size=3,
)
_line_noise = st.binary(max_size=40)
_wrong_size = st.one_of(
    st.binary(min_size=1, max_size=9).map(lambda d: reply_frame(0x07, d)),
    st.binary(min_size=2, max_size=9).map(lambda d: reply_frame(0x01, d)),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    parts=st.lists(st.one_of(_other_replies.map(b"".join), _line_noise, _wrong_size), max_size=4),
    chunks=st.lists(st.integers(1, 20), min_size=1, max_size=5),
)
def test_the_reply_is_found_among_anything(parts: list[bytes], chunks: list[int]) -> None:
    inner = open_transport("sim:mini")
    with NoisyLink(inner, b"".join(parts), chunks) as link:
        client = XgoClient(link, get_profile("mini"), timeout=1.0)
        assert client.firmware() == "M-1.4.1"
        assert client.battery() == 100  # and the next request is not confused by the last
