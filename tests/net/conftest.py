"""Real Zenoh sessions for the net tests: peers on 127.0.0.1, multicast scouting off.

``zenoh_pair`` gives two sessions in this process, the first listening on a free loopback port
and the second connected to it, the way a relay and its conductor meet on one machine.
``two_hosts`` (from :mod:`tests.net.netns`) gives two network namespaces joined by a cable.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator, Sequence

import pytest
import zenoh

from tests.net.netns import two_hosts  # the fixture, for every net test

__all__ = ["free_port", "peer_config", "two_hosts", "zenoh_pair"]


def free_port() -> int:
    """A TCP port nobody listens on right now (the OS picks it)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def peer_config(*, listen: Sequence[str] = (), connect: Sequence[str] = ()) -> zenoh.Config:
    """A peer that stays on the endpoints it is given: no multicast, no gossip beyond them."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
    conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
    return conf


@pytest.fixture
def zenoh_pair() -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """(relay side, conductor side): two connected sessions, closed afterwards."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = zenoh.open(peer_config(listen=[endpoint]))
    b = zenoh.open(peer_config(connect=[endpoint]))
    try:
        yield a, b
    finally:
        b.close()
        a.close()
