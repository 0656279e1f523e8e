"""A scripted robot on a real pty: the test decides what the "robot" answers to each request."""

from __future__ import annotations

import os
import select
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from xgo_show.wire.xarm import XarmDecoder
from xgo_show.wire.xgo import XgoDecoder


class Peer:
    """The robot end of a real pty, answering each complete request with scripted bytes.

    ``path`` is the slave device a client opens; ``master`` lets a test write to it directly.
    """

    def __init__(self, answer: Callable[[Any], bytes], decoder: Any) -> None:
        self.master, slave = os.openpty()
        self.path = os.ttyname(slave)
        self._slave = slave  # held open so the master never sees EOF between clients
        self._answer = answer
        self._decoder = decoder
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="test-peer")
        self._thread.start()

    def _serve(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.02)
            if ready:
                for request in self._decoder.feed(os.read(self.master, 4096)):
                    os.write(self.master, self._answer(request))

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self._slave)


PeerFactory = Callable[[Callable[[Any], bytes]], Peer]


def _factory(decoder_type: type[Any]) -> Iterator[PeerFactory]:
    peers: list[Peer] = []

    def make(answer: Callable[[Any], bytes]) -> Peer:
        peers.append(Peer(answer, decoder_type()))
        return peers[-1]

    yield make
    for peer in peers:
        peer.close()


@pytest.fixture
def xgo_peer() -> Iterator[PeerFactory]:
    """``xgo_peer(answer)``: a Peer calling ``answer(XgoFrame) -> bytes`` per request."""
    yield from _factory(XgoDecoder)


@pytest.fixture
def xarm_peer() -> Iterator[PeerFactory]:
    """``xarm_peer(answer)``: a Peer calling ``answer(XarmPacket) -> bytes`` per request."""
    yield from _factory(XarmDecoder)
