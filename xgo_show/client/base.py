"""What every robot client shares: a transport, a profile, a request/reply exchange, lifetime.

:class:`~xgo_show.client.XgoClient` and :class:`~xgo_show.client.XarmClient` differ in their
protocol (decoder, requests, reply matching); owning the link, the reply timeout and closing
are the same for both and live here.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Generic, TypeVar

from xgo_show.client.exchange import Decoder, Exchange, F
from xgo_show.closing import Closing
from xgo_show.errors import ProfileError
from xgo_show.profiles import Profile
from xgo_show.transports.base import Transport

__all__ = ["DEFAULT_TIMEOUT", "ClientBase"]

#: Seconds to wait for a reply (a real robot answers within a few milliseconds).
DEFAULT_TIMEOUT = 0.5

_C = TypeVar("_C", bound="ClientBase[Any]")


class ClientBase(Closing, Generic[F]):
    """A client of one robot family over ``transport``; a context manager that closes it."""

    #: the profile family this client speaks to, its protocol's name and its robots, for messages
    family = ""
    protocol = ""
    robots = ""

    def __init__(
        self,
        transport: Transport,
        profile: Profile,
        decoder: Decoder[F],
        *,
        timeout: float = DEFAULT_TIMEOUT,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if profile.family != self.family:
            raise ProfileError(
                f"{type(self).__name__} talks to {self.robots}, not {profile.model!r}"
            )
        self.transport = transport
        self.profile = profile
        self._exchange = Exchange(
            transport, decoder, profile.link, protocol=self.protocol, timeout=timeout,
            clock=clock, sleep=sleep,
        )

    @property
    def model(self) -> str:
        return self.profile.model

    @property
    def timeout(self) -> float:
        """Seconds a request waits for its reply (settable)."""
        return self._exchange.timeout

    @timeout.setter
    def timeout(self, seconds: float) -> None:
        self._exchange.timeout = seconds

    def close(self) -> None:
        """Close the transport."""
        self.transport.close()

    def __enter__(self: _C) -> _C:
        if not self.transport.is_open:
            self.transport.open()
        return self

