"""A behaviour in real time on a simulated Rider over a real pty: a fall on the wire makes the
fallen rule play its routine (first frame measured), an offline robot fires the offline rule,
and never two executors write on the port."""

from __future__ import annotations

import contextlib
import itertools
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import wait_until
from tests.loopback import free_port
from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.loader import Behaviour
from xgo_show.behave.ports import BehaviourRunner
from xgo_show.cli.main import main
from xgo_show.profiles import get_profile
from xgo_show.runtime.events import Event, EventBus, FrameSent, TelemetryRead
from xgo_show.runtime.runlog import read_log
from xgo_show.runtime.safety import rest_frames
from xgo_show.sim import create_robot
from xgo_show.sim.pty_server import PtyServer
from xgo_show.transports import open_transport

EXHIBITION = Path(__file__).resolve().parents[2] / "behaviours" / "exhibition" / "exhibition.yaml"


@contextlib.contextmanager
def _on_a_rider(
    behaviour: Behaviour,
) -> Iterator[tuple[BehaviourRunner, PtyServer, list[Event]]]:
    """``behaviour`` running (default rates, 10 s at most) on a simulated Rider on a pty; the
    frames sent and the engine's notes collected. Stopped (and checked ended) on exit."""
    bus = EventBus()
    seen: list[Event] = []
    bus.subscribe(seen.append, FrameSent, BehaviourNote, TelemetryRead)
    with PtyServer(create_robot("rider")) as server:
        transport = open_transport(server.path)
        transport.open()
        runner = BehaviourRunner(behaviour, {"rio": transport}, events=bus)
        thread = threading.Thread(target=runner.run, kwargs={"duration": 10.0})
        thread.start()
        try:
            yield runner, server, seen
        finally:
            runner.stop()
            thread.join(5)
            transport.close()
        assert not thread.is_alive()


def test_fall_and_offline_on_a_pty(tmp_path: Path) -> None:
    (tmp_path / "get_up.yaml").write_text(textwrap.dedent("""\
        show: get up
        performers: {rio: {model: rider}}
        tracks:
          rio: [{move: {body_z: 80}, duration: 0.6}]
        """))
    (tmp_path / "b.yaml").write_text(textwrap.dedent("""\
        behaviour: rider
        performers: {rio: {model: rider}}
        routines: {get_up: get_up.yaml}
        rules:
          - {name: fallen, safety: true, when: [{tilt_beyond: 60}], do: [{play: get_up}]}
          - {name: lost, when: [{offline: 0.5}], do: [{publish: lost}]}
        """))
    behaviour = load_behaviour(tmp_path / "b.yaml")
    with _on_a_rider(behaviour) as (_, server, seen):
        time.sleep(0.2)
        with server.lock:
            fell = time.monotonic()
            server.robot.fall()  # type: ignore[attr-defined]
        wait_until(lambda: any(
            isinstance(e, FrameSent) and e.kind == "frame" for e in list(seen)
        ), timeout=3.0)
        first = next(e for e in list(seen) if isinstance(e, FrameSent) and e.kind == "frame")
        # The status (where a Rider's fall shows) is read every 20 ms (the naive 3-item
        # rotation at 0.25 s read it every 0.75 s and reacted in 0.3-0.5 s), and the rule acts
        # on the first reading that shows the fall, with no wait for a reader to stop. Counted
        # in readings, not milliseconds: a loaded machine slows both alike.
        status = [e for e in list(seen) if isinstance(e, TelemetryRead) and e.name == "status"]
        upright = status[0].value
        shown = next(i for i, e in enumerate(status) if e.value != upright)
        # seen at the first read after the fall (or the next: one may have been in flight)
        assert sum(1 for e in status[:shown] if e.t >= fell) <= 1
        assert first.t >= status[shown].t
        assert sum(1 for e in status if e.t < first.t) - shown <= 3  # acted on within 2 reads
        gaps = sorted(b.t - a.t for a, b in itertools.pairwise(status))
        assert gaps[len(gaps) // 2] < 0.035, gaps  # the median read gap: the 20 ms cadence
        assert first.t - fell < 2.0  # and in real time, bounded
        readers = [t for t in threading.enumerate() if "reader" in t.name]
        assert len(readers) == 1  # one reader on the port, across executors
        server.offline = True
        wait_until(lambda: any(
            isinstance(e, BehaviourNote) and e.kind == "published" for e in list(seen)
        ), timeout=3.0)
    notes = [f"{e.rule} {e.kind}: {e.text}" for e in seen if isinstance(e, BehaviourNote)]
    assert "fallen fired: rio tilted 90 deg > 60" in notes
    assert "fallen action: rio plays get_up" in notes
    assert "lost published: lost" in notes
    # One writer at a time: the frames' write times never go backwards on the port.
    times = [e.t for e in seen if isinstance(e, FrameSent)]
    assert times == sorted(times)


def test_cli_rehearses_a_script_in_real_time_on_ptys(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = tmp_path / "events.yaml"
    script.write_text("duration: 1.5\nevents:\n  - {at: 0.3, trigger: visitor}\n"
                      "  - {at: 0.6, performer: rex, battery: 15}\n")
    log = tmp_path / "run.jsonl"
    assert main(["behave", str(EXHIBITION), "--sim", "--script", str(script),
                 "--log", str(log)]) == 0
    records = read_log(log)
    rules = [(r["rule"], r["what"], r["text"]) for r in records if r["kind"] == "rule"]
    assert ("greet", "fired", "trigger visitor") in rules
    assert ("battery-low", "action", "rex plays sit") in rules
    # The runtime's records too: the frames of the routines, the battery read back.
    assert any(r["kind"] == "frame" and r["send"] == "frame" for r in records)
    assert any(r["kind"] == "telemetry" and r["name"] == "battery" and r["value"] == 15
               for r in records)
    out = [" ".join(line.split()[1:]) for line in capsys.readouterr().out.splitlines()]
    for want in ["rule idle: action: rex loops idle", "script: trigger visitor",
                 "rule greet: action: rex plays greet", "script: rex battery 15%",
                 "rule greet: cut: rex taken by rule battery-low",
                 "rule battery-low: action: rex plays sit"]:
        assert want in out, (want, out)


def test_led_beside_a_loop_and_a_phrase_on_its_own_on_a_pty(tmp_path: Path) -> None:
    (tmp_path / "moves.yaml").write_text(textwrap.dedent("""\
        show: moves
        performers: {rio: {model: rider}}
        phrases:
          sway: {params: {by: 5}, cues: [{move: {roll: [$by, 0]}, duration: 1.2}]}
        tracks:
          rio: [{move: {body_z: 80}, duration: 0.6}, {phrase: sway}]
        """))
    (tmp_path / "b.yaml").write_text(textwrap.dedent("""\
        behaviour: rider
        performers: {rio: {model: rider}}
        routines: {moves: moves.yaml}
        triggers: [red, sway]
        rules:
          - {name: idle, when: [{startup: true}], do: [{loop: moves}]}
          - {name: red, when: [{trigger: red}], do: [{led: {all: red}}]}
          - {name: sway, when: [{trigger: sway}], do: [{play: moves, phrase: sway,
             with: {by: 8}}]}
        """))
    behaviour = load_behaviour(tmp_path / "b.yaml")
    phrase = behaviour.routines["moves.sway(by=8)"].performers[0]
    assert phrase.end == pytest.approx(1.2)
    led = behaviour.writes["red.do[0]"].performers[0].frames[0].data
    with _on_a_rider(behaviour) as (runner, server, seen):
        time.sleep(0.3)
        runner.trigger("red")
        wait_until(lambda: any(isinstance(e, FrameSent) and e.kind == "set"
                               for e in list(seen)))
        assert runner.engine.playing("rio") == "moves"  # the loop was not cut
        runner.trigger("sway")
        wait_until(lambda: runner.engine.playing("rio") is None, timeout=3.0)
        received = [f.data for f in server.robot.received]
    assert led in received  # the colour reached the robot
    notes = [f"{e.rule} {e.kind}: {e.text}" for e in seen if isinstance(e, BehaviourNote)]
    assert "red action: rio led all=red" in notes
    assert "sway action: rio plays moves.sway(by=8)" in notes
    assert not any(n.startswith("idle cut") for n in notes[: notes.index(
        "red action: rio led all=red") + 1])
    # The phrase played on its own: its frames, from its first, nothing of the routine's.
    sway_at = next(e.t for e in seen if isinstance(e, BehaviourNote) and e.rule == "sway"
                   and e.kind == "action")
    frames = [e for e in seen if isinstance(e, FrameSent) and e.kind == "frame"
              and e.t >= sway_at]
    assert [e.data for e in frames[: len(phrase.frames)]] == [f.data for f in phrase.frames]


def test_a_relay_that_does_not_answer_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    port = free_port()
    assert main(["behave", str(EXHIBITION), "--map", "rex=zenoh:nowhere/rex",
                 "--listen", f"tcp/127.0.0.1:{port}"]) != 0
    err = capsys.readouterr().err
    assert "relay nowhere did not answer hello" in err
    assert "Traceback" not in err


def test_a_preempted_routine_hands_over_through_the_default_posture(tmp_path: Path) -> None:
    (tmp_path / "lean.yaml").write_text(textwrap.dedent("""\
        show: lean
        performers: {rio: {model: rider}}
        tracks:
          rio: [{move: {body_z: 80}, duration: 0.6}, {move: {roll: [8, 0]}, duration: 3}]
        """))
    (tmp_path / "b.yaml").write_text(textwrap.dedent("""\
        behaviour: rider
        performers: {rio: {model: rider}}
        routines: {lean: lean.yaml}
        triggers: [again]
        rules:
          - {name: first, when: [{startup: true}], do: [{play: lean}]}
          - {name: again, when: [{trigger: again}], do: [{play: lean}]}
        """))
    behaviour = load_behaviour(tmp_path / "b.yaml")
    with _on_a_rider(behaviour) as (runner, _, seen):
        wait_until(lambda: sum(1 for e in list(seen) if isinstance(e, FrameSent)
                               and e.kind == "frame") > 5)
        cut_at = len(seen)
        runner.trigger("again")
        wait_until(lambda: any(isinstance(e, FrameSent) and e.kind == "frame"
                               and e.index == 0 for e in list(seen)[cut_at:]))
    sent = [e for e in seen[cut_at:] if isinstance(e, FrameSent) and e.kind != "read"]
    first = next(i for i, e in enumerate(sent) if e.kind == "frame" and e.index == 0)
    # Cut mid-move: the rest frames (speeds to neutral), the reset action (default posture),
    # then the routine from its first frame; nothing of the cut routine in between.
    rest = [f.label for f in rest_frames(get_profile("rider"))]
    assert [e.note for e in sent[:first]] == [*rest, "action=255 (restore default posture)"]
