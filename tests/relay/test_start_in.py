"""``start`` with ``start_in``: the relay starts a fixed time after the command arrives, on its
own clock (the naive way, which benchmarks/relay_sync.py compares with a synced start)."""

from __future__ import annotations

import time

import pytest

from tests.relay.conftest import claim
from xgo_show.errors import NetworkError


def test_start_in_starts_after_arrival_and_start_at_with_it_is_refused(
    relays, conductor_session, walk, as_upload, until
) -> None:  # type: ignore[no-untyped-def]
    relay = relays.start("naive", {"rex": "mini"})
    client = claim(conductor_session(relay), relay)
    show = walk(0.3, rex="mini")
    text, sha = as_upload(show)
    client.upload(text, sha)
    with pytest.raises(NetworkError, match="give start_at or start_in"):
        client.request("start", sha256=sha, start_at=time.monotonic() + 1, start_in=1.0, offset=0.0)
    with pytest.raises(NetworkError, match="give start_at or start_in"):
        client.request("start", sha256=sha, offset=0.0)
    sent = time.monotonic()
    client.request("start", sha256=sha, start_in=0.2, offset=0.0)
    planned = {f.data for f in show.performers[0].frames}  # not the pre-flight's reads
    server = relay.servers["rex"]

    def first_frame() -> float | None:
        with server.lock:
            times = [f.t for f in server.robot.received if f.data in planned]
        return times[0] if times else None

    until(lambda: first_frame() is not None, 3.0)
    assert 0.2 <= first_frame() - sent < 0.2 + 0.1  # type: ignore[operator]
    until(lambda: client.command("heartbeat")["show"]["state"] == "ended", 5.0)
    client.stop_heartbeat()
