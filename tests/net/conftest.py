"""Real Zenoh sessions for the net tests: peers on 127.0.0.1, multicast scouting off.

``zenoh_pair`` gives two sessions in this process, the first listening on a free loopback port
and the second connected to it, the way a relay and its conductor meet on one machine.
``two_hosts`` (from :mod:`tests.net.netns`) gives two network namespaces joined by a cable.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from tests.loopback import free_port, peer_config
from tests.net.netns import two_hosts  # the fixture, for every net test

__all__ = ["two_hosts", "zenoh_pair"]


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
