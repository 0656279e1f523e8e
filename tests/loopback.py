"""Zenoh on this machine the way the house rules want it: 127.0.0.1, explicit endpoints,
multicast scouting off."""

from __future__ import annotations

import json
import socket
from collections.abc import Sequence

import zenoh


def free_port() -> int:
    """A TCP port nobody listens on right now on 127.0.0.1 (the OS picks it)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def peer_config(*, listen: Sequence[str] = (), connect: Sequence[str] = ()) -> zenoh.Config:
    """A Zenoh peer that stays on the endpoints it is given: no multicast, no gossip beyond."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
    conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
    return conf


def client_config(endpoint: str) -> zenoh.Config:
    """A Zenoh client of the show's: connected to ``endpoint``, listening on a port of its own."""
    return peer_config(listen=["tcp/127.0.0.1:0"], connect=[endpoint])
