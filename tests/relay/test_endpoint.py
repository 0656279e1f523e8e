"""The conductor's ``zenoh:`` performers (relay/conductor.py) in this process: the endpoint of
one relay over a recording session (tests/relay/recording.py) answered by a scripted relay
and its time server. Configuring, the shared session, grouping performers by relay, claiming a
relay and checking its robots, time sync, the pre-flight rows the relay's upload reply becomes,
the performers, closing, and ``probe zenoh:``. test_conductor.py runs the same against relays
in their own processes over Zenoh."""

from __future__ import annotations

import dataclasses
import itertools
import re
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.conftest import wait_until
from tests.relay.conftest import walk_schedule
from tests.relay.recording import ROBOTS, RecordingSession, ScriptedRelay, answer
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.errors import NetworkError, UsageError
from xgo_show.net.offset import OffsetEstimate, Timebase
from xgo_show.net.session import SessionOptions
from xgo_show.relay import conductor
from xgo_show.relay.conductor import (
    RelayEndpoint,
    close_session,
    configure,
    parse_zenoh_url,
    probe_relayed,
    shared_session,
)
from xgo_show.relay.options import ConductorOptions
from xgo_show.relay.performer import RelayedPerformer
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import EventBus
from xgo_show.runtime.launch import PerformerContext, endpoints_for

OPTIONS = ConductorOptions(session=SessionOptions(namespace="ns"), link_loss="continue",
                           watchdog=2.0, timeout=1.0, name="desk")
@pytest.fixture
def relay() -> ScriptedRelay:
    return ScriptedRelay()


@pytest.fixture
def session(relay: ScriptedRelay, monkeypatch: pytest.MonkeyPatch
            ) -> Iterator[RecordingSession]:
    """This process configured to reach relays through a recording session."""
    for name in ("_options", "_session", "_conductor"):  # restored after the test
        monkeypatch.setattr(conductor, name, getattr(conductor, name))
    rec = RecordingSession(relay)
    configure(OPTIONS, session=rec)
    yield rec


def endpoint(**kwargs: Any) -> RelayEndpoint:
    schedule = walk_schedule(1.0, rex="mini", lola="lite", kim="mini")
    urls = {"rex": "zenoh:hall/dog1", "lola": "zenoh:hall/dog2", "kim": "zenoh:attic/kim"}
    return RelayEndpoint(schedule, "hall", {"rex": "dog1", "lola": "dog2"}, urls, **kwargs)


@pytest.fixture
def opened(session: RecordingSession) -> Iterator[RelayEndpoint]:
    ep = endpoint()
    assert ep.open() == {}
    yield ep
    ep.close()


# --- configuring ---------------------------------------------------------------------------------

@pytest.mark.parametrize(("options", "error"), [
    (ConductorOptions(link_loss="pause"), "link-loss policy 'pause': one of stop, continue"),
    (ConductorOptions(watchdog=0.049), "watchdog 0.049 s: give 0.05 to 60 seconds"),
    (ConductorOptions(watchdog=60.5), "watchdog 60.5 s: give 0.05 to 60 seconds"),
])
def test_configure_refuses_an_unknown_policy_and_a_watchdog_out_of_range(
    options: ConductorOptions, error: str, session: RecordingSession
) -> None:
    with pytest.raises(UsageError) as info:
        configure(options)
    assert str(info.value) == error
    assert conductor._options is OPTIONS  # unchanged


@pytest.mark.parametrize("watchdog", [0.05, 60.0])
def test_configure_takes_a_watchdog_at_its_bounds(watchdog: float,
                                                  session: RecordingSession) -> None:
    options = ConductorOptions(watchdog=watchdog)
    configure(options)
    assert conductor._options is options
    assert shared_session()[0] is session  # the session given before stays


def test_configure_with_a_session_serves_relays_through_it(session: RecordingSession) -> None:
    got, me = shared_session()
    assert got is session and me.name == "desk" and len(me.id) == 32
    assert shared_session() == (got, me)
    schedule = walk_schedule(1.0, rex="mini", lola="lite")
    eps = endpoints_for(schedule, {"rex": "zenoh:hall/dog1", "lola": "zenoh:hall"})
    assert len(eps) == 1 and isinstance(eps[0], RelayEndpoint)
    assert eps[0].map == {"rex": "dog1", "lola": "lola"}
    assert eps[0].options is OPTIONS


def test_the_shared_session_is_opened_on_first_use_and_closed_after_the_show(
    monkeypatch: pytest.MonkeyPatch, session: RecordingSession
) -> None:
    opened: list[tuple[SessionOptions, RecordingSession]] = []

    def open_session(opts: SessionOptions) -> RecordingSession:
        opened.append((opts, RecordingSession()))
        return opened[-1][1]

    monkeypatch.setattr(conductor, "open_session", open_session)
    close_session()
    assert session.closed
    close_session()  # nothing open: nothing to do
    options = ConductorOptions(session=SessionOptions(namespace="other"), name="late")
    configure(options)  # no session given: one is opened from these options when needed
    assert opened == []
    got, me = shared_session()
    assert opened == [(options.session, got)] and me.name == "late"
    assert shared_session()[0] is got and len(opened) == 1
    close_session()
    assert got.closed  # type: ignore[attr-defined]
    assert shared_session()[0] is not got and len(opened) == 2


def test_a_url_names_the_relay_and_the_robot() -> None:
    assert parse_zenoh_url("zenoh:hall/dog1", "rex") == ("hall", "dog1")
    assert parse_zenoh_url("zenoh:hall", "rex") == ("hall", "rex")


def test_performers_are_grouped_by_relay(session: RecordingSession) -> None:
    schedule = walk_schedule(1.0, rex="mini", lola="lite", kim="mini")
    urls = {"rex": "zenoh:hall/dog1", "kim": "zenoh:attic", "lola": "zenoh:hall/dog2"}
    eps = conductor._endpoints(schedule, urls)
    assert all(e.schedule is schedule for e in eps)  # type: ignore[attr-defined]
    assert [(e.relay, e.map, e.urls) for e in eps] == [  # type: ignore[attr-defined]
        ("hall", {"rex": "dog1", "lola": "dog2"},
         {"rex": "zenoh:hall/dog1", "lola": "zenoh:hall/dog2"}),
        ("attic", {"kim": "kim"}, {"kim": "zenoh:attic"}),
    ]


# --- the relay's part of the show ----------------------------------------------------------------

def test_an_endpoint_plays_its_relays_performers_under_the_robot_names(
    session: RecordingSession
) -> None:
    ep = endpoint()
    assert ep.names == ("rex", "lola") and ep.options is OPTIONS
    assert ep.urls == {"rex": "zenoh:hall/dog1", "lola": "zenoh:hall/dog2"}
    part = ep.part()
    assert [(p.name, p.model, p.port) for p in part.performers] == [("dog1", "mini", None),
                                                                    ("dog2", "lite", None)]
    rex = ep.schedule.performers[0]
    assert part.performers[0].frames == rex.frames
    assert dataclasses.replace(part, performers=ep.schedule.performers) == ep.schedule
    mine = ConductorOptions(watchdog=1.0)
    assert endpoint(options=mine).options is mine


# --- opening -------------------------------------------------------------------------------------

def test_opening_claims_the_relay_holds_it_and_syncs_its_clock(
    session: RecordingSession, opened: RelayEndpoint
) -> None:
    (hello,) = session.of("hello")
    assert hello.key == "ns/relay/hall/cmd" and hello.request["conductor"]["name"] == "desk"
    assert 0.9 < hello.timeout <= 1.0  # the options' command timeout
    assert opened.client is not None and opened.description["robots"] == ROBOTS
    beat = opened.client._beat
    assert beat is not None and beat.is_alive()
    hb = session.of("heartbeat")
    assert hb and hb[0].timeout == 2.0  # the options' watchdog
    pings = session.of("ping")
    assert len(pings) == 25 and {q.key for q in pings} == {"ns/relay/hall/time"}
    assert len(session.of("timebase")) == 1
    assert session.of("timebase")[0].request["conductor"] == hello.request["conductor"]["id"]
    assert opened.tracker is not None and opened.timebase is not None
    assert opened.estimate is not None and opened.estimate.rtt >= 0
    assert abs(opened.timebase.offset) < 0.5  # one process, one clock


def test_the_heartbeats_go_every_fifth_of_the_watchdog(session: RecordingSession) -> None:
    ep = endpoint(options=ConductorOptions(session=OPTIONS.session, watchdog=0.25))
    try:
        assert ep.open() == {}
        wait_until(lambda: len(session.of("heartbeat")) >= 4, timeout=5.0)
        first = session.of("heartbeat")
        gaps = [b.at - a.at for a, b in itertools.pairwise(first)]
        assert min(gaps[:3]) < 0.2  # 50 ms apart (a slot missed under load is made up)
        assert {q.timeout for q in first} == {0.25}
    finally:
        ep.close()


def test_a_relay_that_refuses_the_hello_fails_every_performer(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.refuse["hello"] = "relay hall is held by conductor 'bob'"
    ep = endpoint()
    why = "relay hall: relay hall is held by conductor 'bob'"
    assert ep.open() == {"rex": why, "lola": why}
    assert ep.client is None and ep.tracker is None and session.of("heartbeat") == []
    rows = ep.preflight(battery_floor=20.0)
    assert [(r.performer, r.model, r.port, r.opened, r.problems) for r in rows] == [
        ("rex", "mini", "zenoh:hall/dog1", False, [why]),
        ("lola", "lite", "zenoh:hall/dog2", False, [why])]
    assert session.of("upload") == []
    with pytest.raises(NetworkError) as info:
        ep.performers(PerformerContext(FakeClock(), EventBus(), False, 0.0, 0.0))
    assert str(info.value) == "relay hall is not open"
    ep.close()
    assert session.of("release") == []


def test_a_relay_whose_clock_does_not_answer_fails_every_performer(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.time = False
    ep = endpoint()
    errors = ep.open()
    assert set(errors) == {"rex", "lola"} and errors["rex"] == errors["lola"]
    assert errors["rex"] == ("time sync with relay hall failed: ns/relay/hall/time: no answer "
                             "to 25 time-sync pings within 0.5 s each")
    assert ep.tracker is None and ep.client is not None  # held: the stop can still reach it
    rows = ep.preflight(battery_floor=20.0)
    assert [r.problems for r in rows] == [[errors["rex"]], [errors["rex"]]]
    assert session.of("upload") == []
    ep.close()
    assert len(session.of("release")) == 1


def test_robots_the_relay_lacks_or_of_another_model_are_named(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.robots = [{"name": "dog1", "model": "lite"}, {"name": "dog7", "model": "lite"}]
    ep = endpoint()
    try:
        assert ep.open() == {
            "rex": "dog1 on relay hall is a lite, not a mini",
            "lola": "relay hall has no robot 'dog2' (it has dog1, dog7)",
        }
        rows = ep.preflight(battery_floor=20.0)
        assert [r.problems for r in rows] == [
            ["dog1 on relay hall is a lite, not a mini"],
            ["relay hall has no robot 'dog2' (it has dog1, dog7)"]]
    finally:
        ep.close()
    relay.robots = []
    ep = endpoint()
    try:
        assert ep.open()["rex"] == "relay hall has no robot 'dog1' (it has none)"
    finally:
        ep.close()


# --- the pre-flight ------------------------------------------------------------------------------

def test_the_preflight_uploads_the_part_and_returns_the_relay_rows(
    session: RecordingSession, opened: RelayEndpoint
) -> None:
    rows = opened.preflight(battery_floor=15.0)
    (up,) = session.of("upload")
    sent = up.request
    assert (sent["link_loss"], sent["watchdog_ms"], sent["battery_floor"]) == ("continue", 2000,
                                                                               15.0)
    assert sent["sha256"] == opened.sha256 and len(opened.sha256) == 64
    assert sent["schedule"] == schedule_to_bytes(opened.part()).decode("ascii")
    rex, lola = rows
    assert (rex.performer, rex.model, rex.port, rex.opened, rex.firmware, rex.detected,
            rex.battery, rex.voltage, rex.low_latency, rex.problems) == (
        "rex", "mini", "/dev/pts/7", True, "R-1.2", "mini", 81.0, None, True, [])
    assert (lola.performer, lola.port, lola.opened, lola.firmware, lola.detected, lola.battery,
            lola.voltage, lola.low_latency, lola.problems) == (
        "lola", "zenoh:hall/dog2", True, "", None, None, 7.4, False, ["battery low"])
    note = re.compile(r"via relay hall, clock offset [+-]\d+\.\d{6} s \+- \d+\.\d{3} ms, "
                      r"round trip \d+\.\d{3} ms")
    assert rex.notes[0] == "port 115200 baud" and note.fullmatch(rex.notes[1])
    assert len(lola.notes) == 1 and note.fullmatch(lola.notes[0])
    assert opened.timebase is not None and opened.estimate is not None
    assert lola.notes[0] == (
        f"via relay hall, clock offset {opened.timebase.offset:+.6f} s +- "
        f"{opened.timebase.bound * 1e3:.3f} ms, round trip {opened.estimate.rtt * 1e3:.3f} ms")


def test_a_pre_flight_row_the_relay_does_not_send_stays_unopened(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.preflight = [relay.preflight[2]]
    ep = endpoint()
    try:
        ep.open()
        rex, lola = ep.preflight(battery_floor=0.0)
        assert (rex.opened, rex.problems, rex.notes) == (False, [], [])
        assert lola.opened
    finally:
        ep.close()


def test_a_failed_upload_is_a_problem_of_every_opened_row(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.refuse["upload"] = "schedule refused: dog1 link budget"
    ep = endpoint()
    try:
        ep.open()
        rows = ep.preflight(battery_floor=0.0)
        assert [(r.opened, r.problems) for r in rows] == [
            (True, ["relay hall: schedule refused: dog1 link budget"])] * 2
    finally:
        ep.close()


def test_the_sync_note_says_what_is_known() -> None:
    ep = endpoint(options=OPTIONS)
    assert ep._sync_note() == ""
    ep.timebase = Timebase(-0.0012345, 0.0, 0.0, 0.5, 0.0)
    assert ep._sync_note() == ", clock offset -0.001234 s +- 500.000 ms"
    ep.estimate = OffsetEstimate(0.0, 0.0, 0.25, 0.0, 1)
    assert ep._sync_note() == (", clock offset -0.001234 s +- 500.000 ms, round trip "
                               "250.000 ms")


# --- the performers and closing ------------------------------------------------------------------

def test_the_performers_share_one_relay_show_started_on_the_run_clock(
    session: RecordingSession, opened: RelayEndpoint
) -> None:
    opened.preflight(battery_floor=0.0)
    clock, bus = FakeClock(50.0), EventBus()
    beat = opened.client._beat if opened.client else None
    got = opened.performers(PerformerContext(clock, bus, True, 0.0, 10.0))
    assert list(got) == ["rex", "lola"]
    assert all(isinstance(p, RelayedPerformer) for p in got.values())
    show = opened.show
    assert show is not None and all(p.show is show for p in got.values())  # type: ignore[attr-defined]
    assert (show.sha256, show.clock, show.events, show.watchdog, show.synced, show.names) == (
        opened.sha256, clock, bus, 2.0, True, {"rex": "dog1", "lola": "dog2"})
    assert opened.client is not None and opened.client._beat is not beat  # the show's now
    assert got["rex"].schedule is opened.schedule.performers[0]  # type: ignore[attr-defined]
    opened.close()
    assert opened.client is None and opened.tracker is None
    assert len(session.of("release")) == 1


def test_closing_stops_the_clock_tracking_and_gives_the_relay_up(
    session: RecordingSession, opened: RelayEndpoint
) -> None:
    tracker, client = opened.tracker, opened.client
    assert tracker is not None and client is not None
    opened.close()
    assert tracker._stop.is_set() and opened.tracker is None
    assert client._beat is None and len(session.of("release")) == 1
    opened.close()  # again: nothing left to close
    assert len(session.of("release")) == 1


# --- probe zenoh: --------------------------------------------------------------------------------

def test_probe_asks_the_relay_to_read_its_robot_and_gives_it_up(
    monkeypatch: pytest.MonkeyPatch, relay: ScriptedRelay
) -> None:
    rec = RecordingSession(relay)
    opened: list[SessionOptions] = []

    def open_session(opts: SessionOptions) -> RecordingSession:
        opened.append(opts)
        return rec

    monkeypatch.setattr(conductor, "open_session", open_session)
    options = SessionOptions(namespace="ns")
    assert probe_relayed("zenoh:hall/dog1", options, timeout=0.5) == [
        ("relay", "hall"), ("port", "/dev/pts/7"), ("firmware", "12")]
    assert opened == [options] and rec.closed
    hello, probe, release = rec.queries
    assert (hello.op, probe.op, release.op) == ("hello", "probe", "release")
    assert probe.request["performer"] == "dog1" and probe.key == "ns/relay/hall/cmd"
    assert 1.9 < hello.timeout <= 2.0  # a second more than asked, at least 2
    probe_relayed("zenoh:hall/dog1", options, timeout=3.0)
    assert 3.9 < rec.queries[3].timeout <= 4.0


def test_probe_gives_the_relay_up_and_closes_even_when_refused(
    monkeypatch: pytest.MonkeyPatch, relay: ScriptedRelay
) -> None:
    relay.refuse["probe"] = "a show is running"
    rec = RecordingSession(relay)
    monkeypatch.setattr(conductor, "open_session", lambda opts: rec)
    with pytest.raises(NetworkError) as info:
        probe_relayed("zenoh:hall/dog1", SessionOptions(namespace="ns"), timeout=0.5)
    assert str(info.value) == "relay hall: a show is running"
    assert [q.op for q in rec.queries] == ["hello", "probe", "release"] and rec.closed
    relay.refuse = {"hello": "held"}
    rec2 = RecordingSession(relay)
    monkeypatch.setattr(conductor, "open_session", lambda opts: rec2)
    with pytest.raises(NetworkError):
        probe_relayed("zenoh:hall/dog1", SessionOptions(namespace="ns"), timeout=0.5)
    assert [q.op for q in rec2.queries] == ["hello"] and rec2.closed


def test_probe_of_a_relay_without_rows_names_only_the_relay(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    rec = RecordingSession(lambda q: [answer(q, description={})] if q.op == "hello"
                           else [answer(q)])
    monkeypatch.setattr(conductor, "open_session", lambda opts: rec)
    assert probe_relayed("zenoh:hall/dog2", SessionOptions(), timeout=0.5) == [("relay", "hall")]
    assert rec.queries[1].request["performer"] == "dog2"


# --- what the first mutation run showed unchecked ------------------------------------------------

def test_before_opening_an_endpoint_has_no_description_digest_or_rows(
    session: RecordingSession
) -> None:
    ep = endpoint()
    assert (ep.description, ep.sha256, ep.client, ep.show) == ({}, "", None, None)
    rows = ep.preflight(battery_floor=0.0)
    assert [r.problems for r in rows] == [["relay not opened"], ["relay not opened"]]
    assert session.of("upload") == []


def test_the_relays_part_has_no_ports_of_this_host(session: RecordingSession) -> None:
    ep = endpoint()
    ep.schedule = dataclasses.replace(ep.schedule, performers=tuple(
        dataclasses.replace(p, port="/dev/ttyUSB0") for p in ep.schedule.performers))
    assert [p.port for p in ep.part().performers] == [None, None]


def test_a_relay_describing_no_robots_has_none(session: RecordingSession,
                                               relay: ScriptedRelay) -> None:
    session.respond = lambda q: ([answer(q, description={"relay": "hall"})] if q.op == "hello"
                                 else relay(q))
    ep = endpoint()
    try:
        assert ep.open()["lola"] == "relay hall has no robot 'dog2' (it has none)"
    finally:
        ep.close()


def test_an_upload_reply_without_rows_leaves_every_row_unopened(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    session.respond = lambda q: [answer(q)] if q.op == "upload" else relay(q)
    ep = endpoint()
    try:
        assert ep.open() == {}
        rows = ep.preflight(battery_floor=0.0)
        assert [(r.opened, r.problems, r.notes) for r in rows] == [(False, [], [])] * 2
    finally:
        ep.close()


def test_performers_of_a_relay_whose_clock_is_not_tracked_convert_times(
    session: RecordingSession, relay: ScriptedRelay
) -> None:
    relay.time = False
    ep = endpoint()
    ep.open()  # held, but not synced
    got = ep.performers(PerformerContext(FakeClock(), EventBus(), False, 0.0, 0.0))
    assert ep.show is not None and ep.show.synced is False and len(got) == 2
    ep.close()


def test_an_opened_relay_hears_heartbeats_every_fifth_of_the_watchdog(
    session: RecordingSession
) -> None:
    ep = endpoint(options=ConductorOptions(session=OPTIONS.session, watchdog=0.25))
    start = time.monotonic()
    try:
        assert ep.open() == {}
        time.sleep(1.0)
    finally:
        ep.close()
    slots = (time.monotonic() - start) / 0.05
    # A slot missed under load is made up: the count follows the clock, not the waits.
    assert slots * 0.6 <= len(session.of("heartbeat")) <= slots + 1


def test_probe_needs_the_robot_named() -> None:
    with pytest.raises(NetworkError) as info:
        probe_relayed("zenoh:hall", SessionOptions(), timeout=0.5)
    assert str(info.value) == "'zenoh:hall': name the robot too, e.g. zenoh:hall/rex"
