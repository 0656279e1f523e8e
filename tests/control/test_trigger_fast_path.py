"""The trigger fast path of ``xgo-show serve``, from another process over Zenoh on loopback.

A trigger no section of the loaded show waits for is refused before its payload is read and
never reaches the director; one the show waits for always does (the director's own answer
comes back); panic wins over any of them; the counters count each exactly. The serve process
plays the short triggered show of ``conftest.py`` on simulated robots (real ptys) and holds at
section ``b``'s wait (``go``, no timeout) while the drawn triggers come in.
"""

from __future__ import annotations

import json
import os
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.control.conftest import control_session, serve_process
from xgo_show.control.client import ControlClient
from xgo_show.control.keys import event_key, trigger_key
from xgo_show.control.server import _Tally, _trigger_request
from xgo_show.errors import ControlError

NS = f"test-fast-{os.getpid()}"
KNOWN = ("go", "encore")  # the triggers the show's sections wait for
DIRECTOR = "the show waits for 'go' (section 'b')"  # the director's refusal while held at b


@pytest.fixture(scope="module")
def serve(triggered_path: Path) -> Iterator[tuple[subprocess.Popen[str], str]]:
    with serve_process(triggered_path, NS) as (proc, endpoint, _):
        yield proc, endpoint


@pytest.fixture(scope="module")
def session(serve: tuple[subprocess.Popen[str], str]) -> Iterator[zenoh.Session]:
    with control_session(*serve, NS) as s:
        yield s


@pytest.fixture(scope="module")
def events(session: zenoh.Session) -> Iterator[list[dict[str, Any]]]:
    """Every event the server publishes from here on."""
    got: list[dict[str, Any]] = []
    sub = session.declare_subscriber(
        event_key(NS), lambda s: got.append(json.loads(s.payload.to_bytes()))
    )
    ControlClient(session, NS).status()  # the subscription is in place
    yield got
    sub.undeclare()  # type: ignore[no-untyped-call]


@pytest.fixture(scope="module")
def held(session: zenoh.Session, events: list[dict[str, Any]]) -> ControlClient:
    """The show started and holding at section b, waiting for ``go``."""
    client = ControlClient(session, NS, timeout=10.0)
    client.command("start")
    _until(lambda: client.status()["state"] == "waiting")
    return client


def _until(predicate: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("timed out")
        time.sleep(0.01)


def _counters(client: ControlClient) -> dict[str, int]:
    return dict(client.status()["counters"])


# A drawn trigger: (name, put or query, payload). Unknown names include ones a director would
# know nothing of, with payloads good and bad: none of it may matter before the lookup.
unknown_names = st.from_regex(r"\A[A-Za-z_][A-Za-z0-9_-]{0,12}\Z").filter(
    lambda n: n not in KNOWN
)
payloads = st.sampled_from([b"", b"{}", b'{"v": 1, "source": "desk"}', b"{not json", b"[1]"])
fired = st.lists(
    st.tuples(st.one_of(unknown_names, st.just("encore")), st.booleans(), payloads),
    min_size=1, max_size=10,  # at most 100 queries in all: none over the replies' rate
)


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(triggers=fired)
def test_only_a_trigger_the_show_waits_for_reaches_the_director(
    held: ControlClient, session: zenoh.Session, events: list[dict[str, Any]],
    triggers: list[tuple[str, bool, bytes]],
) -> None:
    before = _counters(held)
    seen = len(events)
    replies: list[tuple[str, bytes, dict[str, Any]]] = []
    for name, as_query, payload in triggers:
        key = trigger_key(NS, name)
        if not as_query:
            session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK)
            continue
        answers = list(session.get(key, payload=payload, timeout=5.0))
        assert len(answers) == 1
        err = answers[0].err
        assert err is not None  # nothing here is for the wait the show holds at
        replies.append((name, payload, json.loads(err.payload.to_bytes())))
    unknown = sum(name not in KNOWN for name, _, _ in triggers)
    known_good = sum(name in KNOWN and _good(p) for name, _, p in triggers)
    known_bad = sum(name in KNOWN and not _good(p) for name, _, p in triggers)
    # Puts are counted as they arrive: wait for every one, then the counts are exact.
    _until(lambda: _counters(held)["triggers"] - before["triggers"] >= unknown + known_good)
    _until(lambda: _counters(held)["malformed"] - before["malformed"] >= known_bad)
    after = _counters(held)
    assert after["unknown"] - before["unknown"] == unknown
    assert after["malformed"] - before["malformed"] == known_bad
    assert after["refused"] - before["refused"] == unknown + known_good
    assert after["triggers"] - before["triggers"] == unknown + known_good
    assert after["accepted"] == before["accepted"]
    for name, payload, reply in replies:
        assert reply["error"] in ("refused", "bad_request"), reply
        if name not in KNOWN:  # refused unread, by name: the director never saw it
            assert reply["error"] == "refused"
            assert "no section of this show waits for" in reply["message"]
            assert "(its triggers: encore, go)" in reply["message"]
        elif _good(payload):  # the director's own answer
            assert reply["error"] == "refused" and DIRECTOR in reply["message"], reply
        else:
            assert reply["error"] == "bad_request"
    # The director tells of each refusal it makes (trigger events): never of an unknown one.
    time.sleep(0.05)
    told = {e["trigger"] for e in events[seen:] if e["event"] == "trigger"}
    assert told <= set(KNOWN)
    assert held.status()["state"] == "waiting"


def _good(payload: bytes) -> bool:
    try:
        _trigger_request(payload)
    except ControlError:
        return False
    return True


def test_a_flood_of_unknown_queries_gets_replies_at_a_bounded_rate(
    held: ControlClient, session: zenoh.Session
) -> None:
    from xgo_show.control.server import UNKNOWN_REPLIES

    time.sleep(1.1)  # the replies' rate counts from the first query of a new second
    before = _counters(held)
    answered = silent = 0
    began = time.monotonic()
    for _ in range(UNKNOWN_REPLIES + 50):
        answers = list(session.get(trigger_key(NS, "lights"), timeout=0.3))
        if answers:
            answered += 1
        else:
            silent += 1
    elapsed = time.monotonic() - began
    assert answered + silent == UNKNOWN_REPLIES + 50
    assert answered <= UNKNOWN_REPLIES * (int(elapsed) + 2)
    if elapsed < 1.0:  # all within one second: the rate's limit shows
        assert silent >= 50
    assert _counters(held)["unknown"] - before["unknown"] == UNKNOWN_REPLIES + 50


def test_the_trigger_the_show_waits_for_releases_it_and_panic_wins_over_a_flood(
    held: ControlClient, session: zenoh.Session
) -> None:
    before = _counters(held)
    out = held.trigger("go", source="test")
    assert out["held"] is True and out["section"] == "b"
    assert _counters(held)["accepted"] == before["accepted"] + 1
    stop = threading.Event()

    def flood(name: str) -> None:
        key = trigger_key(NS, name)
        while not stop.is_set():
            session.put(key, b"{}", congestion_control=zenoh.CongestionControl.BLOCK)
            time.sleep(0.0005)

    threads = [threading.Thread(target=flood, args=(n,)) for n in ("lights", "encore", "go")]
    for th in threads:
        th.start()
    try:
        time.sleep(0.2)
        began = time.monotonic()
        panic = held.command("panic")
        assert time.monotonic() - began < 1.0
    finally:
        stop.set()
        for th in threads:
            th.join()
    assert panic["ok"] and panic["state"] in ("ended", "idle", "stopping")
    _until(lambda: held.status()["state"] in ("loaded", "idle"))
    assert held.status()["last_result"]["completed"] is False


def test_a_tally_counts_every_bump_from_many_threads() -> None:
    tally = _Tally()
    reads = []

    def bump() -> None:
        for _ in range(20_000):
            tally.bump()

    threads = [threading.Thread(target=bump) for _ in range(4)]
    for th in threads:
        th.start()
    for _ in range(50):
        reads.append(tally.value())
    for th in threads:
        th.join()
    assert reads == sorted(reads)  # reading takes nothing away
    assert tally.value() == tally.value() == 80_000


def test_a_trigger_payload_is_checked_unless_it_is_one_of_the_empty_ones() -> None:
    assert _trigger_request(None).source is None
    assert _trigger_request(b"{}") is _trigger_request(b"")  # no parse
    assert _trigger_request(b'{"source": "desk", "data": [1]}').source == "desk"
    for bad in (b"{not json", b"[1]", b'{"v": 2}', b'{"colour": 1}'):
        with pytest.raises(ControlError):
            _trigger_request(bad)
