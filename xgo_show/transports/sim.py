"""``sim:<model>``: a simulated robot in the same process, behind the transport interface.

Bytes written go to :meth:`SimulatedRobot.receive` stamped with the injected clock; reads
collect what :meth:`SimulatedRobot.poll` returns, waiting up to the timeout in short sleeps.
With ``clock=fake.now, sleep=fake.advance`` a test runs the robot on a fake clock and a read
with a timeout returns without waiting in real time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from xgo_show.errors import TransportError
from xgo_show.sim.base import SimulatedRobot
from xgo_show.transports.base import Transport

__all__ = ["POLL_INTERVAL", "SimTransport", "open_sim"]

#: Seconds between polls while a read waits (the robot answers within a poll or two).
POLL_INTERVAL = 0.001


class SimTransport(Transport):
    """A transport whose other end is a :class:`SimulatedRobot` in this process.

    ``robot`` is public so callers can inspect what it received (``robot.received``) and its
    state (``robot.snapshot()``). Thread-safe: a writer and a reader thread may share it.
    """

    def __init__(
        self,
        robot: SimulatedRobot,
        *,
        url: str | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        poll_interval: float = POLL_INTERVAL,
    ) -> None:
        super().__init__(url or f"sim:{robot.model}")
        self.robot = robot
        self._clock = clock
        self._sleep = sleep
        self._poll_interval = poll_interval
        self._lock = threading.Lock()
        self._rx = bytearray()
        self._open = False

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False

    @property
    def is_open(self) -> bool:
        return self._open

    def write(self, data: bytes) -> None:
        self._require_open()
        with self._lock:
            self.robot.receive(bytes(data), self._clock())

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        self._require_open()
        deadline = self._clock() + timeout
        while True:
            with self._lock:
                self._rx += self.robot.poll(self._clock())
                if self._rx:
                    out = bytes(self._rx[:size])
                    del self._rx[:size]
                    return out
            left = deadline - self._clock()
            if left <= 0:
                return b""
            self._sleep(min(self._poll_interval, left))

    def _require_open(self) -> None:
        if not self._open:
            raise TransportError(f"{self.url} is not open")


def open_sim(
    url: str,
    *,
    baudrate: int | None = None,
    **options: Any,
) -> SimTransport:
    """Scheme factory: ``sim:mini`` -> a fresh simulated Mini (``baudrate`` is ignored).

    ``clock``, ``sleep`` and ``poll_interval`` go to :class:`SimTransport`; other options go to
    :func:`xgo_show.sim.create_robot` (e.g. ``battery=40``).
    """
    from xgo_show.sim import create_robot

    model = url.partition(":")[2].strip().lower()
    if not model:
        raise TransportError(f"{url}: name a model, e.g. sim:mini, sim:lite, sim:rider, sim:xarm")
    link_options = {k: options.pop(k) for k in _LINK_OPTIONS if k in options}
    return SimTransport(create_robot(model, **options), url=url, **link_options)


_LINK_OPTIONS = ("clock", "sleep", "poll_interval")
