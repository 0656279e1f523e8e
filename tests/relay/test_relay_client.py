"""The conductor's side of the relay protocol (relay/client.py), in this process: a relay on
in-process simulators and its clients share one Zenoh session (no network: multicast off, no
endpoints), so every request is a real Zenoh query, answered by the relay's queryables. The
sequence numbers, the clock offset from the fastest round trip, refusals and silence in words,
heartbeats, losing a relay, and listing the relays of a namespace. The same client in this
process over a recording session, and its parts that need no session at all (the conductor's
identity, the offset arithmetic): test_client_logic.py."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh

from tests.loopback import peer_config
from xgo_show.errors import NetworkError
from xgo_show.net import messages as msg
from xgo_show.relay.client import (
    RelayClient,
    list_relays,
    new_conductor,
)
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots
from xgo_show.relay.server import Relay

from .conftest import upload_text, walk_schedule


@pytest.fixture(scope="module")
def session() -> Iterator[zenoh.Session]:
    s = zenoh.open(peer_config())
    yield s
    s.close()


@pytest.fixture
def namespace() -> str:
    return f"t{uuid.uuid4().hex[:8]}"  # each test its own relays


@pytest.fixture
def robots() -> Iterator[dict[str, OwnedRobot]]:
    owned = open_robots({"rex": "sim:mini"}, {})
    yield owned
    close_robots(owned)


@pytest.fixture
def relay(session: zenoh.Session, robots: dict[str, OwnedRobot], namespace: str
          ) -> Iterator[Relay]:
    r = Relay(session, "hall", robots, namespace=namespace).start()
    yield r
    r.close()


def client(session: zenoh.Session, namespace: str, name: str = "alice",
           relay: str = "hall", timeout: float = 2.0) -> RelayClient:
    return RelayClient(session, relay, namespace=namespace, conductor=new_conductor(name),
                       timeout=timeout)


# --- who we are --------------------------------------------------------------------------------

# --- requests and replies ------------------------------------------------------------------------

def test_hello_claims_the_relay_and_each_request_has_the_next_sequence_number(
    session: zenoh.Session, namespace: str, relay: Relay
) -> None:
    c = client(session, namespace)
    description = c.hello()
    assert description["relay"] == "hall" and description["holder"]["name"] == "alice"
    assert c.request("heartbeat").seq == 2
    assert c.request("heartbeat").seq == 3
    assert c.command("stop", reason="test") == {"stops": {"rex": True}}


def test_a_refusal_is_a_network_error_naming_the_relay(
    session: zenoh.Session, namespace: str, relay: Relay
) -> None:
    client(session, namespace, "alice").hello()
    with pytest.raises(NetworkError) as info:
        client(session, namespace, "bob").hello()
    assert str(info.value) == (
        "relay hall: relay hall is held by conductor 'alice' (id "
        f"{relay.describe()['holder']['id']}); it serves one conductor at a time")


def test_a_relay_that_does_not_answer_is_named_with_the_time_waited(
    session: zenoh.Session, namespace: str
) -> None:
    c = client(session, namespace, relay="nobody", timeout=0.3)
    start = time.monotonic()
    with pytest.raises(NetworkError) as info:
        c.hello()
    waited = time.monotonic() - start
    assert str(info.value) == (
        "relay nobody did not answer hello within 0.3 s (is it running, in the same "
        "namespace, reachable with these endpoints?)")
    assert 0.25 < waited < 2.0
    with pytest.raises(NetworkError, match=r"did not answer release within 0\.1 s"):
        c.request("release", timeout=0.1)


def test_release_is_quiet_when_the_relay_is_gone(session: zenoh.Session, namespace: str
                                                 ) -> None:
    c = client(session, namespace, relay="nobody", timeout=5.0)
    start = time.monotonic()
    c.release()  # waits a second at most, says nothing
    assert time.monotonic() - start < 3.0


def test_the_offset_comes_from_the_fastest_round_trip(session: zenoh.Session,
                                                      namespace: str, relay: Relay) -> None:
    c = client(session, namespace)
    link = c.link
    assert (link.best_rtt, link.offset, link.status, link.lost) == (float("inf"), 0.0, None,
                                                                   False)
    assert link.worst_recent_rtt() is None
    c.hello()
    for _ in range(5):
        c.request("heartbeat")
    assert 0 < link.best_rtt < 0.5
    assert link.best_rtt == min(link.recent)
    # One process, one clock: the relay's clock reads the same as ours.
    assert abs(link.offset) <= link.best_rtt
    assert link.worst_recent_rtt() == max(link.recent)
    assert abs(link.last_reply - time.monotonic()) < 1.0


def test_commands_the_relay_works_on_are_left_out_of_the_recent_round_trips(
    session: zenoh.Session, namespace: str, relay: Relay
) -> None:
    c = client(session, namespace)
    c.hello()
    n = len(c.link.recent)
    c.command("probe", performer="rex")
    c.command("stop", reason="test")
    assert len(c.link.recent) == n
    c.request("heartbeat")
    assert len(c.link.recent) == n + 1


def test_send_hands_the_reply_or_the_refusal_to_its_callback_once(
    session: zenoh.Session, namespace: str, relay: Relay
) -> None:
    c = client(session, namespace)
    got: list[Any] = []
    c.send("hello", got.append)
    deadline = time.monotonic() + 5
    while not got:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert isinstance(got[0], msg.Reply) and got[0].ok and got[0].seq == 1
    refused: list[Any] = []
    client(session, namespace, "bob").send("hello", refused.append)
    while not refused:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert isinstance(refused[0], NetworkError) and "held by conductor 'alice'" in str(
        refused[0])
    time.sleep(0.05)
    assert len(got) == 1 and len(refused) == 1


def test_send_to_a_relay_nobody_runs_says_so_after_its_timeout(
    session: zenoh.Session, namespace: str
) -> None:
    c = client(session, namespace, relay="nobody")
    got: list[Any] = []
    c.send("hello", got.append, timeout=0.2)
    deadline = time.monotonic() + 5
    while not got:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert str(got[0]) == ("relay nobody did not answer hello within 0.2 s (is it running, in "
                           "the same namespace, reachable with these endpoints?)")


def test_an_upload_and_a_start_go_through(session: zenoh.Session, namespace: str,
                                          relay: Relay) -> None:
    c = client(session, namespace)
    c.hello()
    # Held through the pre-flight, which on a loaded machine takes longer than the relay's
    # 500 ms watchdog (the relay then let go of a silent conductor: seen at load 9).
    c.start_heartbeat(period=0.1, watchdog=5.0)
    text, sha = upload_text(walk_schedule(0.3, rex="mini"))
    got = c.upload(text, sha, link_loss="continue", watchdog_ms=800, battery_floor=10.0)
    assert got["sha256"] == sha and got["preflight_ok"] is True
    assert relay._show is not None and relay._show.link_loss == "continue"
    assert relay._show.battery_floor == 10.0
    assert relay._holder is not None
    assert relay._holder.watchdog.timeout == pytest.approx(0.8)
    c.start(sha, relay.clock.now() + 0.3, offset=0.1)
    assert relay._show is not None and relay._show.offset == pytest.approx(0.1)
    c.command("stop", reason="test")
    c.stop_heartbeat()


# --- heartbeats ------------------------------------------------------------------------------------

def test_heartbeats_keep_the_relay_and_bring_its_status(
    session: zenoh.Session, namespace: str, relay: Relay
) -> None:
    c = client(session, namespace)
    c.hello()
    statuses: list[dict[str, Any]] = []
    c.start_heartbeat(period=0.02, watchdog=0.3, on_status=statuses.append)
    c.start_heartbeat(period=0.02, watchdog=0.3)  # once is enough
    time.sleep(0.7)  # longer than the relay's watchdog: the heartbeats keep it
    assert relay.describe()["holder"] is not None
    assert len(statuses) >= 5 and statuses[-1]["state"] == "idle"
    assert c.link.status == statuses[-1]
    thread = c._beat
    assert thread is not None and thread.name == "xgo-show heartbeat hall" and thread.daemon
    c.stop_heartbeat()
    assert c._beat is None and not thread.is_alive()
    n = len(statuses)
    time.sleep(0.1)
    assert len(statuses) == n


def test_a_relay_that_stops_answering_is_lost_once(session: zenoh.Session, namespace: str,
                                                   robots: dict[str, OwnedRobot]) -> None:
    r = Relay(session, "hall", robots, namespace=namespace).start()
    c = client(session, namespace)
    c.hello()
    lost: list[float] = []
    c.start_heartbeat(period=0.02, watchdog=0.2, on_lost=lost.append)
    time.sleep(0.1)
    assert not c.link.lost
    r.close()
    deadline = time.monotonic() + 5
    while not lost:
        assert time.monotonic() < deadline, "the silent relay was never noticed"
        time.sleep(0.005)
    assert c.link.lost and lost[0] >= 0.2
    r2 = Relay(session, "hall", robots, namespace=namespace).start()  # back again
    try:
        time.sleep(0.2)
        assert len(lost) == 1 and c.link.lost  # lost for this show: not heard again
    finally:
        c.stop_heartbeat()
        r2.close()


def test_heartbeats_without_a_callback_still_mark_the_link(session: zenoh.Session,
                                                           namespace: str) -> None:
    c = client(session, namespace, relay="nobody")
    c.start_heartbeat(period=0.02, watchdog=0.1)
    deadline = time.monotonic() + 5
    while not c.link.lost:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    c.stop_heartbeat()


# --- listing -----------------------------------------------------------------------------------------

def test_list_relays_describes_each_live_relay_by_name(
    session: zenoh.Session, namespace: str, robots: dict[str, OwnedRobot]
) -> None:
    assert list_relays(session, namespace, timeout=0.3) == []
    with Relay(session, "zed", robots, namespace=namespace), \
            Relay(session, "amy", {}, namespace=namespace):
        found = list_relays(session, namespace, timeout=0.5)
        assert [d["relay"] for d in found] == ["amy", "zed"]
        assert found[1]["robots"][0]["name"] == "rex" and found[1]["holder"] is None
        assert list_relays(session, namespace + "x", timeout=0.3) == []


def test_a_live_relay_that_does_not_answer_is_listed_as_such(
    session: zenoh.Session, namespace: str
) -> None:
    token = session.liveliness().declare_token(f"{namespace}/relay/mute/alive")
    # Answers that are not descriptions are left out.
    junk = session.declare_queryable(f"{namespace}/relay/junk/info",
                                     lambda q: q.reply(q.key_expr, b"[1, 2]"))
    bad = session.declare_queryable(f"{namespace}/relay/bad/info",
                                    lambda q: q.reply(q.key_expr, b"{not json"))
    try:
        assert list_relays(session, namespace, timeout=0.3) == [
            {"relay": "mute", "state": "not answering", "robots": [], "holder": None}]
    finally:
        token.undeclare()
        junk.undeclare()
        bad.undeclare()
