"""The conductor's side of a behaviour's relayed performers (behave/relayed.py) in this
process, over the recording session (tests/relay/recording.py) in place of Zenoh: what opening
claims and uploads to each relay (each routine's and write's part under the relay's robot
names, by its SHA-256) and its refusals, the commands the engine's actions become (robots,
hashes, a start time on the relay's clock), the lead of a play on several hosts, what the
heartbeats' answers bring back (events, ended plays), a refused command as a fault, a lost
relay, and closing. test_behave_relayed.py plays the same over real relays in other
processes; this file is what behave/relayed.py's mutation run measures."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.behave.conftest import write_behaviour
from tests.behave.relays import AHEAD, Relays
from tests.conftest import wait_until
from tests.relay.recording import RecordingSession
from xgo_show.behave import load_behaviour
from xgo_show.behave.loader import Behaviour
from xgo_show.behave.relayed import MIN_PLAY_LEAD, RelayedStage
from xgo_show.compiler.artifact import schedule_from_bytes
from xgo_show.errors import SetupError
from xgo_show.net import messages as msg
from xgo_show.relay.performer import RTT_FACTOR
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, EventBus, FaultRaised, TelemetryRead

ROUTINES = {"one": {"rex": 1.0}, "duo": {"rex": 1.0, "ada": 2.0}}
URLS = {"rex": "zenoh:hall/dog1", "ada": "zenoh:yard/rio"}
class Rig:
    """A RelayedStage of a behaviour of rex (on hall) and ada (on yard), over ``relays``;
    what it calls back and publishes noted."""

    def __init__(self, tmp_path: Path, relays: Relays | None = None, *,
                 urls: dict[str, str] | None = None, watchdog: float = 5.0,
                 watch: float | None = 0.02) -> None:
        path = write_behaviour(tmp_path, ROUTINES, """\
            - {name: g, when: [{trigger: go}], do: [{play: duo}, {set: {body_z: 90},
               performers: [ada]}]}
            """, "triggers: [go]\n")
        duo = tmp_path / "duo.yaml"  # a routine may name its robots' ports: not a relay's
        duo.write_text(duo.read_text().replace("rex: {model: mini}",
                                               "rex: {model: mini, port: /dev/ttyUSB0}"))
        self.behaviour: Behaviour = load_behaviour(path)
        self.relays = relays if relays is not None else Relays()
        self.session = RecordingSession(self.relays)
        self.events = EventBus()
        self.seen: list[Event] = []
        self.events.subscribe(self.seen.append)
        self.ended: list[tuple[str, int]] = []
        self.lost: list[tuple[tuple[str, ...], str]] = []
        self.stage = RelayedStage(
            self.behaviour, URLS if urls is None else urls,
            session=self.session,  # type: ignore[arg-type]
            conductor=msg.Conductor("c1", "alice"), namespace="ns", clock=MonotonicClock(),
            events=self.events, on_ended=lambda p, i: self.ended.append((p, i)),
            on_lost=lambda ps, why: self.lost.append((ps, why)), watchdog=watchdog,
            watch_interval=watch, telemetry_interval=0.5, timeout=1.0)

    def sent(self, relay: str, *, beats: bool = False) -> list[dict[str, Any]]:
        """The requests sent to ``relay`` (heartbeats left out unless ``beats``), as sent."""
        return [q.request for q in self.session.queries
                if q.key == f"ns/relay/{relay}/cmd" and (beats or q.op != "heartbeat")]

    def ops(self, relay: str) -> list[str]:
        return [r["op"] for r in self.sent(relay)]


def _fields(request: dict[str, Any]) -> dict[str, Any]:
    """A request's own fields (not the protocol's)."""
    common = {"v", "op", "seq", "conductor", "conductor_name", "sent", "t"}
    return {k: v for k, v in request.items() if k not in common}


def test_open_claims_each_relay_uploads_its_parts_and_opens_its_stage(tmp_path: Path) -> None:
    rig = Rig(tmp_path)
    rig.stage.open()
    try:
        assert rig.stage.performers == ("rex", "ada")
        assert rig.ops("hall") == ["hello", "stage_upload", "stage_upload", "stage_open"]
        assert rig.ops("yard") == ["hello", "stage_upload", "stage_upload", "stage_open"]
        hall, yard = rig.stage.relays["hall"], rig.stage.relays["yard"]
        # Each part under the relay's robot names, without a port, kept by its digest.
        uploads = {relay: [_fields(r) for r in rig.sent(relay) if r["op"] == "stage_upload"]
                   for relay in ("hall", "yard")}
        for relay, keys in (("hall", ["one", "duo"]), ("yard", ["duo", "g.do[1]"])):
            names = []
            for key, fields in zip(keys, uploads[relay], strict=True):
                assert fields["sha256"] == schedule_digest(fields["schedule"])
                assert rig.stage.relays[relay].hashes[key] == fields["sha256"]
                schedule = schedule_from_bytes(fields["schedule"].encode("ascii"))
                names.append([(p.name, p.port) for p in schedule.performers])
            assert names == ([[("dog1", None)], [("dog1", None)]] if relay == "hall"
                             else [[("rio", None)], [("rio", None)]])
        assert set(hall.hashes) == {"one", "duo"} and set(yard.hashes) == {"duo", "g.do[1]"}
        # As the conductor given, each command within the timeout given (an upload: 30 s).
        queries = [q for q in rig.session.queries if q.op != "heartbeat"]
        assert {str(q.request["conductor"]) for q in queries} == {str({"id": "c1",
                                                                       "name": "alice"})}
        assert [(q.op, round(q.timeout)) for q in queries if q.key.endswith("hall/cmd")] == [
            ("hello", 1), ("stage_upload", 30), ("stage_upload", 30), ("stage_open", 1)]
        assert _fields(rig.sent("hall")[-1]) == {"robots": ["dog1"], "watch": 0.02,
                                                 "telemetry": 0.5, "watchdog_ms": 5000}
        assert _fields(rig.sent("yard")[-1])["robots"] == ["rio"]
        # Held from then on: heartbeats flow to both.
        wait_until(lambda: all(any(r["op"] == "heartbeat" for r in rig.sent(n, beats=True))
                               for n in ("hall", "yard")), timeout=10.0)
    finally:
        rig.stage.close()
    assert rig.ops("hall")[-2:] == ["stage_stop", "release"]
    assert _fields(rig.sent("hall")[-2]) == {"robots": ["dog1"], "reason": "behaviour ended"}
    stop = [q for q in rig.session.of("stage_stop") if q.key.endswith("hall/cmd")][-1]
    assert round(stop.timeout) == 2


def test_a_relay_alone_in_the_url_plays_the_robot_named_as_the_performer(tmp_path: Path) -> None:
    rig = Rig(tmp_path, urls={"rex": "zenoh:hall", "ada": "zenoh:yard/rio"})
    assert rig.stage.relays["hall"].names == {"rex": "rex"}
    assert rig.stage.relays["yard"].names == {"ada": "rio"}


@pytest.mark.parametrize(("change", "error"), [
    ("missing", "rex: relay hall has no robot 'dog1' (it has dog2, dog3)"),
    ("none", "rex: relay hall has no robot 'dog1' (it has none)"),
    ("no robots", "rex: relay hall has no robot 'dog1' (it has none)"),
    ("model", "rex: dog1 on relay hall is a lite, not a mini"),
    ("refused", "relay hall: held by bob"),
    ("upload", "relay hall: no room"),
])
def test_a_relay_that_cannot_play_its_part_is_a_setup_error_and_is_released(
    tmp_path: Path, change: str, error: str
) -> None:
    relays = Relays()
    if change == "missing":
        relays.robots["hall"] = [{"name": "dog2", "model": "lite"},
                                 {"name": "dog3", "model": "mini"}]
    elif change == "none":
        relays.robots["hall"] = []
    elif change == "no robots":
        relays.described["hall"] = {"relay": "hall"}
    elif change == "model":
        relays.robots["hall"] = [{"name": "dog1", "model": "lite"}]
    elif change == "refused":
        relays.refuse[("hall", "hello")] = "held by bob"
    else:
        relays.refuse[("hall", "stage_upload")] = "no room"
    # yard first: opened, then released when hall fails
    rig = Rig(tmp_path, relays, urls={"ada": URLS["ada"], "rex": URLS["rex"]})
    with pytest.raises(SetupError) as err:
        rig.stage.open()
    assert str(err.value) == error
    assert rig.ops("yard")[-2:] == ["stage_stop", "release"]
    assert rig.ops("hall")[-1] == ("hello" if change == "refused" else "release")
    assert not any(r.opened for r in rig.stage.relays.values())


def test_the_engines_actions_become_commands_to_the_relays_of_their_performers(
    tmp_path: Path,
) -> None:
    rig = Rig(tmp_path, watch=None)
    rig.stage.open()
    try:
        hall, yard = rig.stage.relays["hall"], rig.stage.relays["yard"]
        before = {n: len(rig.sent(n)) for n in ("hall", "yard")}
        rig.stage.play("duo", ("rex", "ada"), 7, 1.0, at=500.0)
        rig.stage.play("one", ("ada", "rex"), 8, 1.0)  # yard (first) has no part of one
        rig.stage.rest(("ada",), 2.0)
        rig.stage.safe_stop(("rex", "ada"), "rule fall", 3.0)
        rig.stage.write("g.do[1]", ("ada", "rex"), 4.0)  # hall has no part of it
        wait_until(lambda: len(rig.sent("hall")) == before["hall"] + 3
                   and len(rig.sent("yard")) == before["yard"] + 4, timeout=10.0)
        new = {n: [(r["op"], _fields(r)) for r in rig.sent(n)[before[n]:]]
               for n in ("hall", "yard")}
        # The start time on each relay's clock: its offset from this one added (as its
        # answers show it, to within their round trip).
        for n in ("hall", "yard"):
            assert new[n][0][1]["at"] == pytest.approx(500.0 + AHEAD[n], abs=0.05)
            new[n][0][1]["at"] = 500.0 + AHEAD[n]
        assert new["hall"] == [
            ("stage_play", {"robots": ["dog1"], "sha256": hall.hashes["duo"], "play": 7,
                            "at": 600.0}),
            ("stage_play", {"robots": ["dog1"], "sha256": hall.hashes["one"], "play": 8,
                            "at": None}),
            ("stage_stop", {"robots": ["dog1"], "reason": "rule fall"}),
        ]
        assert new["yard"] == [
            ("stage_play", {"robots": ["rio"], "sha256": yard.hashes["duo"], "play": 7,
                            "at": 450.0}),
            ("stage_rest", {"robots": ["rio"]}),
            ("stage_stop", {"robots": ["rio"], "reason": "rule fall"}),
            ("stage_write", {"robots": ["rio"], "sha256": yard.hashes["g.do[1]"]}),
        ]
        assert rig.seen == []  # every command accepted: no fault
    finally:
        rig.stage.close()


def test_a_play_on_several_hosts_leads_by_the_slowest_relays_worst_round_trip(
    tmp_path: Path,
) -> None:
    rig = Rig(tmp_path)
    stage = rig.stage
    hall, yard = stage.relays["hall"].client.link, stage.relays["yard"].client.link
    assert (stage.hosts(("rex",)), stage.hosts(("rex", "ada")), stage.hosts(())) == (1, 2, 0)
    assert stage.lead(("rex", "ada")) == MIN_PLAY_LEAD  # no round trip seen yet
    hall.recent.extend([0.01, 0.004])
    yard.recent.extend([0.001])
    assert stage.lead(("rex",)) == RTT_FACTOR * 0.01 / 2
    assert RTT_FACTOR * 0.001 / 2 < MIN_PLAY_LEAD
    assert stage.lead(("ada",)) == MIN_PLAY_LEAD
    assert stage.lead(("ada", "rex")) == RTT_FACTOR * 0.01 / 2
    yard.recent.append(0.02)
    assert stage.lead(("ada", "rex")) == RTT_FACTOR * 0.02 / 2
    assert stage.lead(("rex",)) == RTT_FACTOR * 0.01 / 2
    # A relay lost plays nothing more: it counts neither as a host nor for the lead.
    stage.relays["yard"].lost = "gone"
    assert stage.hosts(("rex", "ada")) == 1
    assert stage.lead(("ada", "rex")) == RTT_FACTOR * 0.01 / 2


def test_a_refused_command_is_a_fault_of_each_performer_of_its_relay(tmp_path: Path) -> None:
    relays = Relays()
    relays.refuse[("yard", "stage_rest")] = "not open"
    rig = Rig(tmp_path, relays, watch=None)
    rig.stage.open()
    try:
        rig.stage.rest(("ada", "rex"), 1.0)
        wait_until(lambda: any(isinstance(e, FaultRaised) for e in list(rig.seen)), timeout=10.0)
        faults = [e for e in rig.seen if isinstance(e, FaultRaised)]
        assert [(e.performer, e.reason) for e in faults] == [
            ("ada", "stage_rest: relay yard: not open")]
        assert 0.0 <= rig.stage.clock.now() - faults[0].t < 5.0  # at the answer, on this clock
    finally:
        rig.stage.close()


def test_heartbeat_answers_bring_the_relays_events_and_ended_plays(tmp_path: Path) -> None:
    relays = Relays()
    rig = Rig(tmp_path, relays)
    rig.stage.open()
    try:
        with relays.lock:
            relays.status["yard"] = {"stage": {"ended": "none"}}
            relays.status["hall"] = {
                "events": [["t", "dog1", "battery", 55.0, 110.0],
                           ["t", "dog2", "battery", 1.0, 110.0]],
                "stage": {"ended": [["dog1", 3], ["dog2", 4], ["dog1", "5"], ["dog1"], "x",
                                    ["dog1", 6]]},
            }
        wait_until(lambda: len(rig.ended) == 2, timeout=10.0)
        assert rig.ended == [("rex", 3), ("rex", 6)]
        reads = [e for e in rig.seen if isinstance(e, TelemetryRead)]
        assert [(e.performer, e.name, e.value) for e in reads] == [("rex", "battery", 55.0)]
        # the relay's time 110 s on this clock: less its offset (100 s, as its answers show)
        assert reads[0].t == pytest.approx(10.0, abs=0.05)
    finally:
        rig.stage.close()


def test_a_silent_relay_is_lost_after_the_watchdog_its_performers_named_and_sent_nothing(
    tmp_path: Path,
) -> None:
    # (only yard's side is checked: on a loaded machine hall's heartbeats may starve too)
    relays = Relays()
    rig = Rig(tmp_path, relays, watchdog=2.0)
    rig.stage.open()
    try:
        relays.silent.add("yard")
        wait_until(lambda: any(ps == ("ada",) for ps, _ in list(rig.lost)), timeout=20.0)
        why = next(why for ps, why in rig.lost if ps == ("ada",))
        assert why.startswith("relay yard lost: no answer for ")
        assert why.endswith(" ms (watchdog 2000 ms); it safe-stops its robots")
        # lost once silent for the watchdog's time (its heartbeats' own, not a default)
        assert int(why.split("no answer for ")[1].split(" ms")[0]) >= 2000
        assert rig.stage.relays["yard"].lost == why
        sent = len(rig.sent("yard"))
        rig.stage.play("duo", ("rex", "ada"), 1, 1.0)
        rig.stage.rest(("ada",), 2.0)
        assert len(rig.sent("yard")) == sent
    finally:
        rig.stage.close()
    # Closing: the lost relay is released (sent again while it stays silent) without a stop:
    # its watchdog stopped its robots.
    assert set(rig.ops("yard")[sent:]) == {"release"}


def test_a_lost_relay_is_said_in_milliseconds(tmp_path: Path) -> None:
    rig = Rig(tmp_path, watchdog=0.25)
    rig.stage._on_lost("yard", rig.stage.relays["yard"], 1.2345)
    assert rig.lost == [(("ada",), "relay yard lost: no answer for 1234 ms (watchdog 250 ms); "
                                  "it safe-stops its robots")]


def test_heartbeats_go_every_fifth_of_the_watchdog_without_a_watch_interval(
    tmp_path: Path,
) -> None:
    # The k-th heartbeat never goes before k periods after the first was due (a late one is
    # followed by the next sooner, never earlier than its own time): 0.2 s here.
    rig = Rig(tmp_path, watchdog=1.0, watch=None)
    rig.stage.open()
    try:
        def beats() -> list[float]:
            return [q.at for q in list(rig.session.queries)
                    if q.op == "heartbeat" and q.key.endswith("hall/cmd")]

        wait_until(lambda: len(beats()) >= 11, timeout=10.0)
        times = beats()
        # (less a period: the first may have gone a little after its own time)
        assert all(t - times[0] >= (k - 1) * 0.2 for k, t in enumerate(times))
    finally:
        rig.stage.close()


def test_close_releases_only_the_relays_opened_and_once(tmp_path: Path) -> None:
    rig = Rig(tmp_path, watch=None)
    rig.stage.close("never opened")
    assert rig.session.queries == []
    rig.stage.open()
    rig.stage.close("show over")
    rig.stage.close("again")
    for relay, robots in (("hall", ["dog1"]), ("yard", ["rio"])):
        stops = [_fields(r) for r in rig.sent(relay) if r["op"] == "stage_stop"]
        assert stops == [{"robots": robots, "reason": "show over"}]
        assert rig.ops(relay).count("release") == 1


def test_close_stops_and_releases_each_relay_opened_even_when_a_stop_is_refused(
    tmp_path: Path,
) -> None:
    relays = Relays()
    relays.refuse[("yard", "stage_stop")] = "busy"
    rig = Rig(tmp_path, relays, watch=None)
    rig.stage.open()
    rig.stage.relays["hall"].opened = False  # as if never opened: left alone
    rig.stage.close()
    assert "stage_stop" not in rig.ops("hall") and "release" not in rig.ops("hall")
    assert rig.ops("yard")[-2:] == ["stage_stop", "release"]
    assert not rig.stage.relays["yard"].opened
    rig.stage.relays["hall"].client.stop_heartbeat()  # (its heartbeats: the test's to end)


def test_requests_are_json_of_the_relay_protocol(tmp_path: Path) -> None:
    # (what _fields leaves out is the protocol's own: checked once here)
    rig = Rig(tmp_path, watch=None)
    rig.stage.open()
    rig.stage.close()
    first = json.loads(rig.session.queries[0].payload)
    assert first["op"] == "hello" and first["v"] == msg.PROTOCOL_VERSION
