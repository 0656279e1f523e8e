"""Clock sync (net/timesync.py) in this process, both sides: the relay's time server and the
conductor's measurement and tracker talk through tests/relay/recording.py's session, looped
back (queriers and gets delivered straight to the queryable's callback). The payloads' limits
and refusals, what a ping is stamped with, which timebase is taken and what the reply says, a
held-back reply, the exchange a ping makes, the querier's options, and the tracker's first
burst, push, rounds, refusals and failure. test_timesync.py runs the same over real Zenoh
sessions, which mutmut's forked tests cannot use."""

from __future__ import annotations

import json
import math
import threading
import time
from typing import Any

import pytest
import zenoh

from tests.conftest import wait_until
from tests.relay.recording import Answer, Incoming, Querier, RecordingSession
from xgo_show.errors import TimeSyncError
from xgo_show.net import timesync as ts
from xgo_show.net.offset import Timebase
from xgo_show.net.testhooks import DelayInjector
from xgo_show.net.timesync import (
    MAX_PAYLOAD,
    SYNC_VERSION,
    ClockTracker,
    TrackerUpdate,
    measure,
    serve_time,
)

KEY = "ns/relay/r1/time"


class Ticking:
    """A clock that moves ``step`` on every reading (and jumps to a deadline it waits for)."""

    def __init__(self, start: float, step: float = 0.001) -> None:
        self.t, self.step = start, step
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            t = self.t
            self.t += self.step
            return t

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        if interrupt is not None and interrupt.wait(0.001):
            return False
        with self._lock:
            self.t = max(self.t, deadline)
        return True


def looped() -> RecordingSession:
    """A session both sides use: the relay's queryables answer the conductor's queriers and
    gets."""
    return RecordingSession(loopback=True)


def answer(q: Incoming) -> dict[str, Any]:
    ((key, data),) = q.replies
    assert key == KEY and q.errors == []
    out: dict[str, Any] = json.loads(data)
    return out


def error(q: Incoming) -> str:
    (data,) = q.errors
    assert q.replies == []
    got = json.loads(data)
    assert set(got) == {"v", "error"} and got["v"] == 1
    return str(got["error"])


def ask(net: RecordingSession, body: dict[str, Any] | bytes) -> Incoming:
    data = body if isinstance(body, bytes) else json.dumps(body).encode()
    q = Incoming(KEY, data)
    net.queryables[KEY](q)
    return q


# --- payloads --------------------------------------------------------------------------------

def test_a_payload_is_compact_json_of_at_most_1024_bytes() -> None:
    assert (SYNC_VERSION, MAX_PAYLOAD) == (1, 1024)
    assert ts._encode({"v": 1, "seq": 2}) == b'{"v":1,"seq":2}'
    head = b'{"v":1,"pad":"'
    exact = head + b"x" * (1024 - len(head) - 2) + b'"}'
    assert len(exact) == 1024 and ts._decode(exact)["v"] == 1
    with pytest.raises(ValueError, match=r"^time-sync payload of 1025 bytes \(at most 1024\)$"):
        ts._decode(exact[:-2] + b'x"}')


@pytest.mark.parametrize(("data", "says"), [
    (b"{nope", "time-sync payload is not JSON"),
    (b"[1, 2]", "time-sync payload is not a JSON object"),
    (b'{"v": 2}', "time-sync version 2, this side speaks 1"),
    (b"{}", "time-sync version None, this side speaks 1"),
])
def test_a_payload_that_is_not_this_protocol_is_refused(data: bytes, says: str) -> None:
    with pytest.raises(ValueError) as info:
        ts._decode(data)
    assert str(info.value) == says


@pytest.mark.parametrize("value", [True, "1", None, math.inf, -math.inf, math.nan, [1]])
def test_a_field_must_be_a_finite_number(value: Any) -> None:
    with pytest.raises(ValueError) as info:
        ts._number({"t1": value}, "t1")
    assert str(info.value) == "time-sync field 't1' must be a finite number"


def test_a_whole_number_field_is_read_as_a_float() -> None:
    got = ts._number({"t1": 3}, "t1")
    assert got == 3.0 and isinstance(got, float)


def tb_fields(**over: float) -> dict[str, float]:
    return {"offset": 2.0, "rate": 1e-5, "ref": 10.0, "bound": 1e-4, "rate_bound": 1e-6, **over}


def test_a_timebase_is_read_field_by_field_and_kept_in_range() -> None:
    assert ts._timebase(tb_fields()) == Timebase(2.0, 1e-5, 10.0, 1e-4, 1e-6)
    for fine in ({"rate": 0.00999}, {"rate": -0.00999}, {"bound": 0.0}, {"rate_bound": 0.0}):
        ts._timebase(tb_fields(**fine))
    for bad in ({"rate": 0.01}, {"rate": -0.01}, {"bound": -1e-9}, {"rate_bound": -1e-9}):
        with pytest.raises(ValueError) as info:
            ts._timebase(tb_fields(**bad))
        assert str(info.value) == "time-sync timebase out of range (|rate| < 1%, bounds >= 0)"


# --- the relay's time server -----------------------------------------------------------------

def test_a_ping_is_stamped_on_arrival_and_before_the_reply_express() -> None:
    net, clock = looped(), Ticking(50.0, step=1.0)
    server = serve_time(net, KEY, clock)  # type: ignore[arg-type]
    q = ask(net, {"v": 1, "op": "ping", "seq": 7})
    assert answer(q) == {"v": 1, "seq": 7, "t1": 50.0, "t2": 51.0}
    assert q.express == [True]
    server.close()
    assert net.undeclared == [("queryable", KEY)]


def test_a_timebase_goes_to_its_taker_with_the_conductors_id() -> None:
    net = looped()
    taken: list[tuple[Timebase, str]] = []

    def take(timebase: Timebase, conductor: str) -> float:
        taken.append((timebase, conductor))
        return -1.5e-5

    serve_time(net, KEY, Ticking(1.0), on_timebase=take)  # type: ignore[arg-type]
    q = ask(net, {"v": 1, "op": "timebase", "conductor": "c9", **tb_fields()})
    assert answer(q) == {"v": 1, "ok": True, "correction": -1.5e-5}
    assert taken == [(Timebase(2.0, 1e-5, 10.0, 1e-4, 1e-6), "c9")]


def test_a_taker_that_returns_no_float_gets_a_plain_ok() -> None:
    net = looped()
    serve_time(net, KEY, Ticking(1.0), on_timebase=lambda tb, who: None)  # type: ignore[arg-type]
    q = ask(net, {"v": 1, "op": "timebase", "conductor": "c9", **tb_fields()})
    assert answer(q) == {"v": 1, "ok": True}


def refuse(timebase: Timebase, conductor: str) -> float:
    raise TimeSyncError("relay r1: timebase from a conductor that does not hold it")


@pytest.mark.parametrize(("body", "taker", "says"), [
    ({"v": 1, "op": "dance"}, None, "time-sync op 'dance' (expected ping or timebase)"),
    ({"v": 1, "op": "timebase", **tb_fields()}, refuse,
     "time-sync timebase without a conductor id"),
    ({"v": 1, "op": "timebase", "conductor": 5, **tb_fields()}, refuse,
     "time-sync timebase without a conductor id"),
    ({"v": 1, "op": "timebase", "conductor": "c9", **tb_fields()}, None,
     "this clock takes no timebase"),
    ({"v": 1, "op": "timebase", "conductor": "c9", **tb_fields()}, refuse,
     "relay r1: timebase from a conductor that does not hold it"),
    ({"v": 1, "op": "timebase", "conductor": "c9", **tb_fields(rate=0.5)}, refuse,
     "time-sync timebase out of range (|rate| < 1%, bounds >= 0)"),
    (b"garbage", None, "time-sync payload is not JSON"),
])
def test_a_request_the_server_cannot_take_gets_an_error_reply(
    body: dict[str, Any] | bytes, taker: Any, says: str,
) -> None:
    net = looped()
    serve_time(net, KEY, Ticking(1.0), on_timebase=taker)  # type: ignore[arg-type]
    assert error(ask(net, body)) == says
    assert answer(ask(net, {"v": 1, "op": "ping", "seq": 1}))["seq"] == 1  # still serving


def test_a_delay_holds_each_ping_reply_back_after_stamping_it() -> None:
    net, clock = looped(), Ticking(50.0, step=1.0)
    server = serve_time(net, KEY, clock, delay=DelayInjector(0.05))  # type: ignore[arg-type]
    sent = time.monotonic()
    q = ask(net, {"v": 1, "op": "ping", "seq": 3})
    assert q.replies == []  # not from the callback: from the delay thread, later
    assert q.done.wait(5.0)
    assert time.monotonic() - sent >= 0.05
    assert answer(q) == {"v": 1, "seq": 3, "t1": 50.0, "t2": 51.0}  # stamped on arrival
    assert q.threads == ["xgo-show time-sync delay"] and q.express == [True] and q.dropped
    (th,) = [t for t in threading.enumerate() if t.name == "xgo-show time-sync delay"]
    assert th.daemon
    server.close()
    assert not th.is_alive()


def test_every_answer_holds_off_first_and_a_ping_between_its_two_stamps() -> None:
    net, clock = looped(), Ticking(50.0, step=1.0)
    held: list[float] = []  # the clock's reading when the server held off

    def hold_off() -> None:  # a relay's: while one of its writers is due
        held.append(clock.now())

    serve_time(net, KEY, clock, hold_off=hold_off)  # type: ignore[arg-type]
    q = ask(net, {"v": 1, "op": "ping", "seq": 7})
    assert answer(q) == {"v": 1, "seq": 7, "t1": 50.0, "t2": 52.0}  # the hold read 51
    assert held == [51.0]
    ask(net, {"v": 1, "op": "dance"})  # a refused one too: the hold comes before reading it
    assert len(held) == 2


# --- the conductor's side --------------------------------------------------------------------

def served(relay_start: float = 5000.0) -> RecordingSession:
    net = looped()
    serve_time(net, KEY, Ticking(relay_start))  # type: ignore[arg-type]
    return net


def test_a_ping_is_one_exchange_of_four_readings() -> None:
    net = served()
    querier = net.declare_querier(KEY, timeout=0.5)
    x = ts._ping(querier, Ticking(100.0), 4)  # type: ignore[arg-type]
    assert x is not None
    assert (x.t0, x.t1, x.t2, x.t3) == (100.0, 5000.0, 5000.001, 100.001)
    assert json.loads(querier.payloads[0]) == {"v": 1, "op": "ping", "seq": 4}


def answering(reply: bytes | None) -> RecordingSession:
    """A relay that answers every ping with ``reply`` (bytes) or an error reply."""
    return RecordingSession(lambda q: [Answer(err=b"no") if reply is None else Answer(ok=reply)])


@pytest.mark.parametrize("reply", [
    None, b"{nope", b'{"v":1,"seq":5,"t1":1.0,"t2":2.0}', b'{"v":1,"seq":4,"t1":"x","t2":2.0}',
    b'{"v":2,"seq":4,"t1":1.0,"t2":2.0}',
])
def test_a_ping_without_a_good_reply_makes_no_exchange(reply: bytes | None) -> None:
    net = answering(reply)
    assert ts._ping(net.declare_querier(KEY, timeout=0.5), Ticking(1.0), 4) is None  # type: ignore[arg-type]
    assert ts._ping(Querier(looped(), KEY, 0.5), Ticking(1.0), 4) is None  # type: ignore[arg-type]


def test_measure_pings_through_one_querier_and_agrees_on_the_offset() -> None:
    net = served()
    est = measure(net, KEY, clock=Ticking(100.0))  # type: ignore[arg-type]
    assert est.samples == 25 and est.consistent
    assert est.offset == pytest.approx(4900.0, abs=1e-9)
    (querier,) = net.queriers
    assert querier.key == KEY and querier.options == {
        "timeout": 0.5, "target": zenoh.QueryTarget.ALL,
        "consolidation": zenoh.ConsolidationMode.NONE, "express": True}
    assert net.undeclared == [("querier", KEY)]
    assert measure(served(), KEY, n=3, clock=Ticking(1.0), timeout=0.2).samples == 3  # type: ignore[arg-type]


def test_measure_without_answers_says_how_many_pings_went_unanswered() -> None:
    net = looped()
    with pytest.raises(TimeSyncError) as info:
        measure(net, KEY, n=4, timeout=0.25)  # type: ignore[arg-type]
    assert str(info.value) == f"{KEY}: no answer to 4 time-sync pings within 0.25 s each"
    assert net.undeclared == [("querier", KEY)]  # withdrawn all the same


# --- the tracker -----------------------------------------------------------------------------

def relay_taking(net: RecordingSession, taker: Any, step: float = 0.001) -> None:
    serve_time(net, KEY, Ticking(5000.0, step), on_timebase=taker)  # type: ignore[arg-type]


def test_the_tracker_starts_with_a_burst_pushes_it_and_keeps_tracking() -> None:
    net = looped()
    taken: list[tuple[Timebase, str]] = []
    relay_taking(net, lambda tb, who: taken.append((tb, who)))
    updates: list[TrackerUpdate] = []
    tracker = ClockTracker(net, KEY, conductor="c7", clock=Ticking(100.0), interval=0.5,  # type: ignore[arg-type]
                           burst=3, first=5, on_update=updates.append)
    assert tracker.timebase is None
    tb = tracker.start()
    try:
        assert tb.offset == pytest.approx(4900.0, abs=1e-6)
        # start() returns the first burst's timebase; the tracker keeps the newest from then
        # on (its rounds may already have run here: their clock jumps to each round's time)
        assert updates[0].timebase == tb
        assert taken[0] == (tb, "c7")
        assert updates[0].pushed and updates[0].error == "" and updates[0].estimate.samples == 5
        wait_until(lambda: len(updates) >= 3, timeout=5.0)
        assert [u.estimate.samples for u in updates[1:3]] == [3, 3]
        (th,) = [t for t in threading.enumerate() if t.name == "xgo-show clock tracker"]
        assert th.daemon
    finally:
        tracker.close()
    assert not th.is_alive()
    assert tracker.timebase == updates[-1].timebase  # the newest round's, kept
    assert net.undeclared == [("querier", KEY)]
    seqs = [json.loads(p)["seq"] for p in net_payloads(net)]
    assert seqs[:11] == list(range(1, 12))  # numbered on from burst to burst
    push = net.gets()[0]
    assert (push.key, push.timeout, push.congestion_control) == (
        KEY, 0.5, zenoh.CongestionControl.BLOCK)
    pushed = json.loads(push.payload)
    assert pushed == {"v": 1, "op": "timebase", "conductor": "c7", "offset": tb.offset,
                      "rate": tb.rate, "ref": tb.ref, "bound": tb.bound,
                      "rate_bound": tb.rate_bound}
    assert tracker.failure == ""


def net_payloads(net: RecordingSession) -> list[bytes]:
    """Every ping payload sent through the session's queriers, in order."""
    return [p for q in net.queriers for p in q.payloads]


def test_the_tracker_waits_its_interval_between_rounds() -> None:
    net = served()
    clock = Ticking(100.0)
    tracker = ClockTracker(net, KEY, conductor="c7", clock=clock, interval=2.0, burst=2,  # type: ignore[arg-type]
                           first=2, push=False)
    tracker.start()
    start = clock.t
    wait_until(lambda: len(net_payloads(net)) >= 2 + 2 * 3, timeout=5.0)
    tracker.close()
    assert clock.t >= start + 3 * 2.0 - 0.1  # three rounds, each after a 2 s wait
    assert net.gets() == []  # push=False only measures


def test_only_measuring_reports_rounds_as_not_pushed() -> None:
    net = served()
    updates: list[TrackerUpdate] = []
    tracker = ClockTracker(net, KEY, conductor="c7", clock=Ticking(1.0), push=False,  # type: ignore[arg-type]
                           on_update=updates.append)
    tracker.start()
    tracker.close()
    assert updates[0].pushed is False and updates[0].error == "" and net.gets() == []


def test_a_refused_timebase_fails_the_start_with_the_relays_words() -> None:
    net = looped()
    relay_taking(net, refuse)
    tracker = ClockTracker(net, KEY, conductor="c7", clock=Ticking(1.0))  # type: ignore[arg-type]
    with pytest.raises(TimeSyncError) as info:
        tracker.start()
    assert str(info.value) == f"{KEY}: relay r1: timebase from a conductor that does not hold it"
    assert net.undeclared == [("querier", KEY)]
    assert not [t for t in threading.enumerate() if t.name == "xgo-show clock tracker"]


def test_no_answer_at_all_fails_the_start() -> None:
    net = looped()
    tracker = ClockTracker(net, KEY, conductor="c7", clock=Ticking(1.0), first=6,  # type: ignore[arg-type]
                           timeout=0.2)
    with pytest.raises(TimeSyncError) as info:
        tracker.start()
    assert str(info.value) == f"{KEY}: no answer to 6 time-sync pings within 0.2 s each"
    assert net.undeclared == [("querier", KEY)]


def test_a_round_before_start_is_a_programming_error() -> None:
    with pytest.raises(RuntimeError, match=r"^ClockTracker\.round before start$"):
        ClockTracker(looped(), KEY, conductor="c7").round(3)  # type: ignore[arg-type]


def pushed(replies: list[Answer]) -> RecordingSession:
    """A relay whose timebase answers are ``replies`` (pings answered by a real server)."""
    net = looped()
    serve_time(net, KEY, Ticking(5000.0))  # type: ignore[arg-type]
    pings = net.respond
    net.respond = lambda q: pings(q) if q.via_querier else replies
    return net


@pytest.mark.parametrize(("replies", "says"), [
    ([Answer(err=b'{"v":1,"error":"not the holder"}')], "not the holder"),
    ([Answer(err=b"plain words")], "plain words"),
    ([Answer(err=b"")], "timebase refused"),
    ([Answer()], "timebase refused"),  # neither a sample nor an error
    ([], "no answer to the timebase within 0.5 s"),
])
def test_a_push_says_why_it_did_not_take(replies: list[Answer], says: str) -> None:
    tracker = ClockTracker(pushed(replies), KEY, conductor="c7", clock=Ticking(1.0))  # type: ignore[arg-type]
    with pytest.raises(TimeSyncError) as info:
        tracker.start()
    assert str(info.value) == f"{KEY}: {says}"


def test_a_session_closing_under_the_tracker_stops_it_and_says_why() -> None:
    net = served()
    updates: list[TrackerUpdate] = []
    tracker = ClockTracker(net, KEY, conductor="c7", clock=Ticking(1.0), interval=0.01,  # type: ignore[arg-type]
                           push=False, on_update=updates.append)
    tracker.start()
    net.broken = True
    wait_until(lambda: tracker.failure != "", timeout=5.0)
    assert tracker.failure == f"clock tracking of {KEY} stopped: session closed"
    tracker.close()


# --- what the first mutation run left ---------------------------------------------------------

def test_a_query_without_a_payload_gets_an_error_reply() -> None:
    net = looped()
    serve_time(net, KEY, Ticking(1.0))  # type: ignore[arg-type]
    q = Incoming(KEY, None)
    net.queryables[KEY](q)
    assert error(q) == "time-sync payload is not JSON"


def test_closing_a_server_on_a_closed_session_is_quiet() -> None:
    net = looped()
    server = serve_time(net, KEY, Ticking(1.0))  # type: ignore[arg-type]

    def closed() -> None:
        raise zenoh.ZError("session closed")

    server._queryable.undeclare = closed  # type: ignore[method-assign]
    server.close()


def test_measure_numbers_its_pings_from_1() -> None:
    net = served()
    measure(net, KEY, n=4, clock=Ticking(1.0))  # type: ignore[arg-type]
    assert [json.loads(p)["seq"] for p in net_payloads(net)] == [1, 2, 3, 4]


def test_the_trackers_defaults() -> None:
    from xgo_show.runtime.clock import MonotonicClock

    net = looped()
    # The tracker reads the real clock here: a relay clock that stands still between its two
    # readings keeps every round trip at least zero, however fast this machine answers.
    relay_taking(net, lambda tb, who: None, step=0.0)
    tracker = ClockTracker(net, KEY, conductor="c7")  # type: ignore[arg-type]
    assert (tracker.interval, tracker.burst, tracker.first, tracker.timeout, tracker.push) == (
        1.0, 8, 25, 0.5, True)
    assert isinstance(tracker.clock, MonotonicClock)
    tracker.start()
    tracker.close()
    assert net.queriers[0].options["timeout"] == 0.5
    assert len(net_payloads(net)) >= 25


def test_a_closed_tracker_has_no_querier_left_to_ping_with() -> None:
    tracker = ClockTracker(served(), KEY, conductor="c7", clock=Ticking(1.0), push=False)  # type: ignore[arg-type]
    tracker.start()
    tracker.close()
    with pytest.raises(RuntimeError, match=r"^ClockTracker\.round before start$"):
        tracker.round(2)


@pytest.mark.parametrize(("replies", "says"), [
    ([Answer(err=b"\xff not utf-8")], "\ufffd not utf-8"),
    ([Answer(err=b'{"v":1}')], '{"v":1}'),  # no "error" field: the reply as it came
])
def test_a_push_refusal_is_read_whatever_its_bytes(replies: list[Answer], says: str) -> None:
    tracker = ClockTracker(pushed(replies), KEY, conductor="c7", clock=Ticking(1.0))  # type: ignore[arg-type]
    with pytest.raises(TimeSyncError) as info:
        tracker.start()
    assert str(info.value) == f"{KEY}: {says}"
