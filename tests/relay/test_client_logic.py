"""The conductor's side of the relay protocol (relay/client.py) in this process, over a
recording session (tests/relay/recording.py) in place of Zenoh: what each command sends, how
replies, refusals, error replies and silence come back, the resend while a route is learnt,
the clock offset and recent round trips, the heartbeats and losing a relay, and listing the
relays. test_relay_client.py runs the same client against a relay over a real Zenoh session;
this file is what relay/client.py's mutation run measures."""

from __future__ import annotations

import getpass
import os
import socket
import threading
import time
from collections.abc import Sequence
from typing import Any

import pytest
import zenoh

from tests.conftest import wait_until
from tests.relay.recording import (
    Answer,
    Query,
    RecordingSession,
    answer,
    replying,
    silent,
)
from xgo_show.errors import NetworkError
from xgo_show.net import messages as msg
from xgo_show.relay.client import (
    RECENT_RTTS,
    WORKED_ON,
    RelayClient,
    RelayLink,
    list_relays,
    new_conductor,
)

UNANSWERED = ("(is it running, in the same namespace, reachable with these endpoints?)")


def client(session: RecordingSession, timeout: float = 2.0, relay: str = "hall"
           ) -> RelayClient:
    return RelayClient(session, relay, namespace="ns",  # type: ignore[arg-type]
                       conductor=msg.Conductor("c1", "alice"), timeout=timeout)


# --- who we are ----------------------------------------------------------------------------------

def test_a_conductor_has_a_fresh_id_and_a_name_for_people() -> None:
    a, b = new_conductor("desk"), new_conductor("desk")
    assert a.name == "desk" and a.id != b.id and len(a.id) == 32
    int(a.id, 16)
    me = new_conductor()
    assert me.name == f"{getpass.getuser()}@{socket.gethostname()} pid {os.getpid()}"


@pytest.mark.parametrize("error", [KeyError, OSError])
def test_without_a_user_name_the_conductor_is_someone(monkeypatch: pytest.MonkeyPatch,
                                                     error: type[Exception]) -> None:
    def nobody() -> str:
        raise error("no passwd entry")

    monkeypatch.setattr(getpass, "getuser", nobody)
    assert new_conductor().name == f"someone@{socket.gethostname()} pid {os.getpid()}"


def test_a_client_names_a_relay_by_a_key_chunk() -> None:
    s = RecordingSession()
    c = RelayClient(s, "hall")  # type: ignore[arg-type]
    assert (c.relay, c.namespace, c.timeout, c.key) == ("hall", "xgo-show", 3.0,
                                                        "xgo-show/relay/hall/cmd")
    assert len(c.conductor.id) == 32 and c.conductor != RelayClient(s, "hall").conductor
    assert client(s).key == "ns/relay/hall/cmd"
    with pytest.raises(NetworkError):
        RelayClient(s, "a/b")  # type: ignore[arg-type]


# --- requests and replies ------------------------------------------------------------------------

def test_a_request_is_one_query_to_the_relay_with_the_next_sequence_number() -> None:
    s = RecordingSession(replying)
    c = client(s)
    before = time.monotonic()
    reply = c.request("pause", at=5.0)
    assert (reply.seq, reply.ok, reply.relay) == (1, True, "hall")
    (q,) = s.queries
    assert q.key == "ns/relay/hall/cmd"
    assert q.congestion_control == zenoh.CongestionControl.BLOCK  # never dropped
    assert 1.9 < q.timeout <= 2.0
    sent = q.request
    assert (sent["op"], sent["seq"], sent["conductor"], sent["at"], sent["v"]) == (
        "pause", 1, {"id": "c1", "name": "alice"}, 5.0, msg.PROTOCOL_VERSION)
    assert before <= sent["sent"] <= time.monotonic()
    assert c.request("heartbeat").seq == 2
    assert [q.seq for q in s.queries] == [1, 2]
    c.request("heartbeat", timeout=0.5)
    assert 0.4 < s.queries[-1].timeout <= 0.5


def test_sequence_numbers_stay_unique_across_threads() -> None:
    s = RecordingSession(replying)
    c = client(s)
    threads = [threading.Thread(target=lambda: [c.request("heartbeat") for _ in range(50)])
               for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(q.seq for q in s.queries) == list(range(1, 201))


def test_a_refusal_is_a_network_error_naming_the_relay() -> None:
    s = RecordingSession(lambda q: [answer(q, error="relay hall is held by conductor 'bob'")])
    with pytest.raises(NetworkError) as info:
        client(s).hello()
    assert str(info.value) == "relay hall: relay hall is held by conductor 'bob'"


def test_an_error_reply_is_a_network_error_with_its_text() -> None:
    s = RecordingSession(lambda q: [Answer(err="no such queryable ✓".encode())])
    with pytest.raises(NetworkError) as info:
        client(s).request("stop", reason="x")
    assert str(info.value) == "relay hall: stop: no such queryable ✓"
    s.respond = lambda q: [Answer(err=b"bad \xff")]  # not UTF-8: read anyway
    with pytest.raises(NetworkError) as info:
        client(s).request("stop")
    assert str(info.value) == "relay hall: stop: bad \ufffd"
    s.respond = lambda q: [Answer(err=b"")]
    with pytest.raises(NetworkError) as info:
        client(s).request("stop")
    assert str(info.value) == "relay hall: stop: error reply"


def test_a_reply_to_another_request_is_refused() -> None:
    s = RecordingSession(lambda q: [answer(q, seq=q.seq + 6)])
    with pytest.raises(NetworkError) as info:
        client(s).request("hello")
    assert str(info.value) == "relay hall: hello: reply to request 7"


def test_only_the_first_reply_counts() -> None:
    s = RecordingSession(lambda q: [answer(q, n=1), answer(q, error="second")])
    assert client(s).request("heartbeat").fields == {"n": 1}


def test_a_relay_that_does_not_answer_is_named_with_the_time_waited() -> None:
    s = RecordingSession(silent)
    c = client(s, timeout=0.3, relay="nobody")
    start = time.monotonic()
    with pytest.raises(NetworkError) as info:
        c.hello()
    waited = time.monotonic() - start
    assert str(info.value) == f"relay nobody did not answer hello within 0.3 s {UNANSWERED}"
    # Sent again and again while no route is known, with what is left of the time.
    assert 0.24 < waited < 1.5
    assert len(s.queries) >= 3 and {q.seq for q in s.queries} == {1}
    assert all(q.payload == s.queries[0].payload for q in s.queries)
    timeouts = [q.timeout for q in s.queries]
    assert timeouts == sorted(timeouts, reverse=True) and timeouts[0] <= 0.3
    assert min(timeouts) >= 0.01
    gaps = [b.at - a.at for a, b in zip(s.queries, s.queries[1:], strict=False)]
    assert min(gaps) >= 0.015  # not a busy loop
    with pytest.raises(NetworkError, match=r"^relay nobody did not answer release within 0\.1 s"):
        c.request("release", timeout=0.1)


def test_a_request_unanswered_at_first_goes_through_once_the_route_is_learnt() -> None:
    def later(q: Query) -> Sequence[Answer]:
        return [answer(q, found=True)] if len(s.queries) >= 3 else []

    s = RecordingSession(later)
    reply = client(s).request("hello")
    assert reply.fields == {"found": True} and reply.seq == 1 and len(s.queries) == 3


def test_a_request_near_its_deadline_is_not_sent_again() -> None:
    s = RecordingSession(silent)
    with pytest.raises(NetworkError):
        client(s, timeout=0.04).request("hello")
    assert len(s.queries) == 1  # 50 ms before the deadline, no resend: it could not arrive


def test_the_offset_comes_from_the_fastest_round_trip_and_recent_ones_from_the_network() -> None:
    delays = {"heartbeat": 0.0, "probe": 0.0}

    def relay(q: Query) -> Sequence[Answer]:
        time.sleep(delays[q.op])
        return [answer(q, relay_time=time.monotonic() + 100.0)]

    s = RecordingSession(relay)
    c = client(s)
    link = c.link
    assert (link.best_rtt, link.offset, link.status, link.lost, link.last_reply) == (
        float("inf"), 0.0, None, False, float("-inf"))
    assert link.worst_recent_rtt() is None
    c.request("heartbeat")
    assert abs(link.last_reply - time.monotonic()) < 0.5
    assert len(link.recent) == 1 and link.best_rtt == link.recent[0] < 0.5
    assert abs(link.offset - 100.0) <= link.best_rtt
    best = link.best_rtt
    delays["heartbeat"] = best + 0.05
    c.request("heartbeat")  # slower: its offset is not taken
    assert link.best_rtt == best and len(link.recent) == 2
    assert link.worst_recent_rtt() == max(link.recent) > best + 0.05
    c.command("probe", performer="rex")  # the relay worked on it: not a recent round trip
    assert len(link.recent) == 2


def test_commands_the_relay_works_on_are_left_out_of_the_recent_round_trips() -> None:
    s = RecordingSession(replying)
    c = client(s)
    for op in ("upload", "probe", "stop"):
        c.request(op)
    assert len(c.link.recent) == 0 and c.link.best_rtt < 1.0  # but their offsets count
    for op in ("hello", "start", "pause", "heartbeat", "release"):
        c.request(op)
    assert len(c.link.recent) == 5


def test_learning_keeps_the_lowest_round_trip_and_the_recent_network_ones() -> None:
    c = client(RecordingSession())
    c._learn(10.0, 10.2, 110.1)  # rtt 0.2, midpoint 10.1: offset 100
    assert (c.link.best_rtt, c.link.offset) == (pytest.approx(0.2), pytest.approx(100.0))
    c._learn(20.0, 20.1, 120.06)  # faster: taken
    assert (c.link.best_rtt, c.link.offset) == (pytest.approx(0.1), pytest.approx(100.01))
    c._learn(30.0, 30.5, 200.0)  # slower: its offset is not taken
    assert c.link.offset == pytest.approx(100.01)
    c._learn(40.0, 40.1, 140.0)  # as fast as the best: taken (the newest of equals)
    assert c.link.offset == pytest.approx(99.95)
    c._learn(50.0, 50.01, 150.0, network=False)  # the relay worked on it: not recent
    assert [round(r, 6) for r in c.link.recent] == [0.2, 0.1, 0.5, 0.1]
    assert c.link.best_rtt == pytest.approx(0.01)  # but the offset it gives is good
    assert c.link.last_reply == 50.01


def test_the_link_keeps_the_last_round_trips_only() -> None:
    link = RelayLink()
    for i in range(RECENT_RTTS + 5):
        link.recent.append(float(i))
    assert RECENT_RTTS == 32
    assert list(link.recent) == [float(i) for i in range(5, RECENT_RTTS + 5)]
    assert link.worst_recent_rtt() == RECENT_RTTS + 4
    assert {"upload", "probe", "stop"} == WORKED_ON
    assert RelayLink().recent.maxlen == RECENT_RTTS and RelayLink().recent is not link.recent


# --- commands ------------------------------------------------------------------------------------

def test_hello_returns_the_relay_description() -> None:
    s = RecordingSession(lambda q: [answer(q, description={"relay": "hall", "robots": []})])
    assert client(s).hello() == {"relay": "hall", "robots": []}
    assert s.queries[0].op == "hello"


@pytest.mark.parametrize("description", [None, [1], "hall"])
def test_a_hello_reply_without_a_description_is_refused(description: Any) -> None:
    extra = {} if description is None else {"description": description}
    s = RecordingSession(lambda q: [answer(q, **extra)])
    with pytest.raises(NetworkError) as info:
        client(s).hello()
    assert str(info.value) == "relay hall: hello reply without a description"


def test_an_upload_sends_the_schedule_and_its_settings_and_returns_the_reply_fields() -> None:
    s = RecordingSession(lambda q: [answer(q, sha256="abc", preflight=[{"performer": "rex"}])])
    c = client(s)
    got = c.upload("TEXT", "abc", link_loss="continue", watchdog_ms=800, battery_floor=10.0)
    assert got == {"sha256": "abc", "preflight": [{"performer": "rex"}]}
    sent = s.queries[0].request
    assert {k: sent[k] for k in ("op", "schedule", "sha256", "link_loss", "watchdog_ms",
                                 "battery_floor")} == {
        "op": "upload", "schedule": "TEXT", "sha256": "abc", "link_loss": "continue",
        "watchdog_ms": 800, "battery_floor": 10.0}
    assert 29.0 < s.queries[0].timeout <= 30.0  # a pre-flight takes long: its own timeout
    c.upload("T2", "def")
    sent = s.queries[1].request
    assert (sent["link_loss"], sent["watchdog_ms"], sent["battery_floor"]) == ("stop", 500, None)
    c.upload("T3", "ghi", timeout=5.0)
    assert 4.0 < s.queries[2].timeout <= 5.0


def test_a_start_names_the_show_its_time_and_offset() -> None:
    s = RecordingSession(replying)
    c = client(s)
    c.start("abc", 12.5, offset=0.25)
    c.start("abc", 13.0)
    starts = [q.request for q in s.of("start")]
    assert [(r["sha256"], r["start_at"], r["offset"]) for r in starts] == [
        ("abc", 12.5, 0.25), ("abc", 13.0, 0.0)]


def test_a_command_returns_its_reply_fields() -> None:
    s = RecordingSession(lambda q: [answer(q, stops={"rex": True})])
    assert client(s).command("stop", reason="test") == {"stops": {"rex": True}}
    assert s.queries[0].request["reason"] == "test"


def test_release_gives_the_relay_up_within_a_second_and_quietly_if_it_is_gone() -> None:
    s = RecordingSession(replying)
    client(s, timeout=5.0).release()
    (q,) = s.queries
    assert q.op == "release" and 0.9 < q.timeout <= 1.0
    client(s, timeout=0.5).release()
    assert 0.4 < s.queries[-1].timeout <= 0.5
    s.respond = silent
    start = time.monotonic()
    client(s, timeout=5.0).release()  # says nothing
    assert time.monotonic() - start < 3.0
    s.respond = lambda q: [answer(q, error="not held")]
    client(s).release()


def test_release_stops_the_heartbeats_first() -> None:
    s = RecordingSession(replying)
    c = client(s)
    c.start_heartbeat(period=0.01, watchdog=1.0)
    wait_until(lambda: len(s.of("heartbeat")) >= 2)
    c.release()
    assert c._beat is None
    n = len(s.of("heartbeat"))
    time.sleep(0.05)
    assert len(s.of("heartbeat")) == n and s.queries[-1].op == "release"


# --- send: commands in flight together ----------------------------------------------------------

def test_send_hands_the_reply_to_its_callback_once() -> None:
    s = RecordingSession(lambda q: [answer(q, margin=0.1), answer(q, margin=0.2)])
    c = client(s)
    got: list[Any] = []
    c.send("start", got.append, sha256="abc", start_at=3.0, offset=0.0)
    assert len(got) == 1 and isinstance(got[0], msg.Reply)
    assert got[0].fields == {"margin": 0.1} and got[0].seq == 1
    q = s.queries[0]
    assert (q.key, q.op, q.request["start_at"]) == ("ns/relay/hall/cmd", "start", 3.0)
    assert q.congestion_control == zenoh.CongestionControl.BLOCK
    assert q.timeout == 2.0
    c.send("pause", got.append, timeout=0.5, at=1.0)
    assert s.queries[1].timeout == 0.5 and s.queries[1].seq == 2
    assert len(c.link.recent) >= 2  # its round trips count like the others


def test_send_hands_a_refusal_or_an_error_reply_as_a_network_error() -> None:
    s = RecordingSession(lambda q: [answer(q, error="too late"), answer(q)])
    got: list[Any] = []
    client(s).send("start", got.append)
    assert len(got) == 1 and isinstance(got[0], NetworkError)
    assert str(got[0]) == "relay hall: too late"
    s.respond = lambda q: [Answer(err=b"boom")]
    client(s).send("seek", got.append)
    assert [str(g) for g in got[1:]] == ["relay hall: seek: boom"]


def test_send_to_a_relay_that_does_not_answer_says_so_after_its_timeout() -> None:
    s = RecordingSession(silent, hold=True)
    got: list[Any] = []
    client(s, relay="nobody").send("hello", got.append, timeout=0.2)
    assert got == []  # nothing yet: it waits for the answer
    s.queries[0].deliver([])  # the query ends without an answer
    assert len(got) == 1 and isinstance(got[0], NetworkError)
    assert str(got[0]) == f"relay nobody did not answer hello within 0.2 s {UNANSWERED}"
    s.queries[0].deliver([])
    assert len(got) == 1


def test_send_on_a_closed_session_says_it_was_not_sent() -> None:
    def closed(q: Query) -> Sequence[Answer]:
        raise zenoh.ZError("session closed")

    got: list[Any] = []
    client(RecordingSession(closed)).send("pause", got.append)
    assert len(got) == 1 and isinstance(got[0], NetworkError)
    assert str(got[0]) == "relay hall: pause not sent: session closed"


def test_send_answers_from_several_threads_reach_the_callback_once() -> None:
    s = RecordingSession(silent, hold=True)
    got: list[Any] = []
    client(s).send("pause", got.append)
    q = s.queries[0]
    threads = [threading.Thread(target=q.deliver, args=([answer(q)],)) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(got) == 1


# --- heartbeats ----------------------------------------------------------------------------------

def test_heartbeats_go_every_period_and_bring_the_relay_status() -> None:
    n = [0]

    def relay(q: Query) -> Sequence[Answer]:
        n[0] += 1
        return [answer(q, show={"state": "idle", "n": n[0]}, relay_time=time.monotonic() + 7)]

    s = RecordingSession(relay)
    c = client(s)
    statuses: list[dict[str, Any]] = []
    c.start_heartbeat(period=0.02, watchdog=0.5, on_status=statuses.append)
    first = c._beat
    c.start_heartbeat(period=0.02, watchdog=0.5)  # once is enough
    assert c._beat is first
    assert first is not None and first.name == "xgo-show heartbeat hall" and first.daemon
    wait_until(lambda: len(statuses) >= 5)
    beats = s.of("heartbeat")
    assert {q.key for q in beats} == {"ns/relay/hall/cmd"}
    assert all(q.timeout == 0.5 and q.congestion_control == zenoh.CongestionControl.BLOCK
               for q in beats)
    assert [q.seq for q in beats] == list(range(1, len(beats) + 1))
    assert statuses[:3] == [{"state": "idle", "n": i} for i in (1, 2, 3)]
    assert c.link.status in statuses and abs(c.link.offset - 7) < 0.5
    assert len(c.link.recent) >= 5
    c.stop_heartbeat()
    assert c._beat is None and not first.is_alive()
    count = len(s.of("heartbeat"))
    time.sleep(0.1)
    assert len(s.of("heartbeat")) == count
    c.stop_heartbeat()  # again: nothing to do


def test_heartbeats_keep_their_period_on_average() -> None:
    s = RecordingSession(replying)
    c = client(s)
    start = time.monotonic()
    c.start_heartbeat(period=0.05, watchdog=1.0)
    time.sleep(0.5)
    c.stop_heartbeat()
    slots = (time.monotonic() - start) / 0.05
    # A slot missed under load is made up: the count follows the clock, not the waits.
    assert slots / 2 <= len(s.of("heartbeat")) <= slots + 2


def test_a_relay_that_stops_answering_is_lost_once_and_hears_no_more_heartbeats() -> None:
    answering = [True]
    s = RecordingSession(lambda q: [answer(q, show={"state": "idle"})] if answering[0] else [])
    c = client(s)
    lost: list[float] = []
    statuses: list[Any] = []
    c.start_heartbeat(period=0.02, watchdog=0.2, on_lost=lost.append, on_status=statuses.append)
    wait_until(lambda: len(statuses) >= 3)
    assert not c.link.lost and lost == []
    answering[0] = False
    wait_until(lambda: lost, timeout=5.0)
    assert c.link.lost and lost[0] >= 0.2
    # No heartbeat after it is lost: a relay that was only frozen must still apply its policy.
    wait_until(lambda: c._beat is not None and not c._beat.is_alive())
    count = len(s.of("heartbeat"))
    answering[0] = True
    time.sleep(0.15)
    assert len(s.of("heartbeat")) == count and len(lost) == 1
    c.stop_heartbeat()


def test_heartbeats_without_callbacks_still_mark_the_link() -> None:
    s = RecordingSession(lambda q: [answer(q, show={"state": "idle"})])
    c = client(s)
    c.start_heartbeat(period=0.02, watchdog=0.5)
    wait_until(lambda: c.link.status == {"state": "idle"})
    c.stop_heartbeat()
    s2 = RecordingSession(silent)
    c2 = client(s2)
    c2.start_heartbeat(period=0.02, watchdog=0.1)
    wait_until(lambda: c2.link.lost, timeout=5.0)
    c2.stop_heartbeat()


@pytest.mark.parametrize("bad", ["refusal", "error", "garbage", "no-ok"])
def test_answers_that_are_not_a_good_reply_do_not_keep_the_relay(bad: str) -> None:
    def relay(q: Query) -> Sequence[Answer]:
        if bad == "refusal":
            return [answer(q, error="not held", show={"state": "idle"})]
        if bad == "error":
            return [Answer(err=b"no")]
        if bad == "garbage":
            return [Answer(b"{not json")]
        return [Answer()]

    s = RecordingSession(relay)
    c = client(s)
    lost: list[float] = []
    statuses: list[Any] = []
    c.start_heartbeat(period=0.02, watchdog=0.15, on_lost=lost.append, on_status=statuses.append)
    wait_until(lambda: lost, timeout=5.0)
    c.stop_heartbeat()
    assert statuses == [] and c.link.status is None and len(c.link.recent) == 0


def test_a_status_that_is_not_a_mapping_is_not_passed_on() -> None:
    s = RecordingSession(lambda q: [answer(q, show=["idle"])])
    c = client(s)
    statuses: list[Any] = []
    lost: list[float] = []
    c.start_heartbeat(period=0.02, watchdog=0.2, on_status=statuses.append, on_lost=lost.append)
    wait_until(lambda: len(s.of("heartbeat")) >= 15, timeout=5.0)
    c.stop_heartbeat()
    assert statuses == [] and c.link.status is None and lost == []  # but the relay is heard


def test_an_answer_still_in_flight_when_the_heartbeats_stop_is_not_heard() -> None:
    s = RecordingSession(silent, hold=True)
    c = client(s)
    statuses: list[Any] = []
    c.start_heartbeat(period=0.02, watchdog=1.0, on_status=statuses.append)
    wait_until(lambda: s.held("heartbeat"))
    c.stop_heartbeat()
    for q in s.held("heartbeat"):
        q.deliver([answer(q, show={"state": "idle"})])
    assert statuses == [] and len(c.link.recent) == 0


def test_an_answer_after_the_relay_was_lost_is_not_heard() -> None:
    s = RecordingSession(silent, hold=True)
    c = client(s)
    statuses: list[Any] = []
    lost: list[float] = []
    c.start_heartbeat(period=0.02, watchdog=0.1, on_status=statuses.append, on_lost=lost.append)
    wait_until(lambda: lost, timeout=5.0)
    c._beat_stop.clear()  # as if the answer came before the thread saw the stop
    for q in s.held("heartbeat")[:1]:
        q.deliver([answer(q, show={"state": "idle"})])
    c.stop_heartbeat()
    assert statuses == [] and len(lost) == 1


def test_the_heartbeat_round_trip_is_measured_from_its_own_sending() -> None:
    s = RecordingSession(silent, hold=True)
    c = client(s)
    c.start_heartbeat(period=1.0, watchdog=2.0)
    wait_until(lambda: s.held("heartbeat"))
    time.sleep(0.1)
    q = s.held("heartbeat")[0]
    q.deliver([answer(q)])
    c.stop_heartbeat()
    assert len(c.link.recent) == 1 and 0.1 <= c.link.recent[0] < 1.0


def test_heartbeats_end_when_the_session_closes_without_losing_the_relay() -> None:
    def closed(q: Query) -> Sequence[Answer]:
        raise zenoh.ZError("closed")

    s = RecordingSession(closed)
    c = client(s)
    lost: list[float] = []
    c.start_heartbeat(period=0.02, watchdog=0.1, on_lost=lost.append)
    thread = c._beat
    assert thread is not None
    thread.join(2.0)
    assert not thread.is_alive() and len(s.queries) == 1
    time.sleep(0.2)  # the watchdog stopped with the thread
    assert lost == [] and not c.link.lost
    c.stop_heartbeat()


def test_the_watchdog_counts_from_the_start_of_the_heartbeats() -> None:
    s = RecordingSession(silent)
    c = client(s)
    before = time.monotonic()
    c.start_heartbeat(period=0.02, watchdog=1.0)
    assert before <= c.link.last_reply <= time.monotonic()
    c.stop_heartbeat()


def test_an_answer_with_neither_a_sample_nor_an_error_is_an_error_reply() -> None:
    s = RecordingSession(lambda q: [Answer()])
    with pytest.raises(NetworkError) as info:
        client(s).request("pause")
    assert str(info.value) == "relay hall: pause: error reply"


def test_heartbeats_by_default_every_tenth_of_a_second_with_half_a_second_to_answer() -> None:
    s = RecordingSession(replying)
    c = client(s)
    c.start_heartbeat()
    try:
        wait_until(lambda: len(s.of("heartbeat")) >= 2, timeout=1.0)
        assert s.of("heartbeat")[0].timeout == 0.5
        watchdogs = [t.name for t in threading.enumerate() if "watchdog" in t.name]
        assert "xgo-show watchdog relay hall" in watchdogs
    finally:
        c.stop_heartbeat()


def test_stopping_the_heartbeats_does_not_hang_on_a_stuck_session() -> None:
    stuck = threading.Event()

    def frozen(q: Query) -> Sequence[Answer]:
        stuck.wait(10.0)  # a query blocked in a congested session
        return []

    s = RecordingSession(frozen)
    c = client(s)
    c.start_heartbeat(period=0.02, watchdog=5.0)
    wait_until(lambda: s.queries)
    start = time.monotonic()
    c.stop_heartbeat()
    try:
        assert time.monotonic() - start < 3.0 and c._beat is None
    finally:
        stuck.set()


# --- listing -------------------------------------------------------------------------------------

def info(relay: object, key: str = "ns/relay/x/info") -> Answer:
    return Answer(msg.encode({"relay": relay, "robots": []}), key=key)


def test_list_relays_describes_each_live_relay_by_name_and_flags_the_silent_ones() -> None:
    answers = [info("zed"), info("amy"), Answer(b"[1, 2]"), Answer(b"{not json"),
               info(5), Answer(err=b"x"), Answer(msg.encode({"relay": "bob"}))]
    s = RecordingSession(lambda q: answers if q.key == "ns/relay/*/info" else [],
                         alive=["ns/relay/amy/alive", "ns/relay/mute/alive", "alone"])
    found = list_relays(s, "ns", timeout=0.3)  # type: ignore[arg-type]
    assert found == [
        {"relay": "amy", "robots": []},
        {"relay": "bob"},
        {"relay": "mute", "state": "not answering", "robots": [], "holder": None},
        {"relay": "zed", "robots": []},
    ]
    assert s.liveliness_gets == [("ns/relay/*/alive", 0.3)]
    assert [(q.key, q.timeout) for q in s.queries] == [("ns/relay/*/info", 0.3)]


def test_list_relays_reads_a_relay_name_in_a_namespace_of_several_levels() -> None:
    s = RecordingSession(silent, alive=["site/a/relay/amy/alive"])
    assert list_relays(s, "site/a") == [  # type: ignore[arg-type]
        {"relay": "amy", "state": "not answering", "robots": [], "holder": None}]


def test_list_relays_defaults_to_the_namespace_and_a_second() -> None:
    s = RecordingSession(silent)
    assert list_relays(s) == []  # type: ignore[arg-type]
    assert s.liveliness_gets == [("xgo-show/relay/*/alive", 1.0)]
    assert [(q.key, q.timeout) for q in s.queries] == [("xgo-show/relay/*/info", 1.0)]
