"""The engine on virtual time: modes, priorities and pre-emption, hysteresis, offline/online,
timers, sets; and the bundled exhibition rehearsed from its script with the trace checked."""

from __future__ import annotations

import datetime as dt
import textwrap
from pathlib import Path

import pytest

from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote, Engine
from xgo_show.cli.main import main
from xgo_show.runtime.events import Event, TelemetryRead
from xgo_show.runtime.runlog import read_log

ROOT = Path(__file__).resolve().parents[2]
ROUTINES = ROOT / "behaviours" / "exhibition" / "routines"


class Recorder:
    """A stage that records what it is asked to do."""

    def __init__(self) -> None:
        self.calls: list[tuple[float, str, str, tuple[str, ...], int]] = []

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        self.calls.append((t, "play", routine, performers, play_id))

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        self.calls.append((t, "rest", "", performers, 0))

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        self.calls.append((t, "safe_stop", reason, performers, 0))


def engine_for(tmp_path: Path, rules: str, extra: str = "") -> tuple[Engine, Recorder, list[str]]:
    path = tmp_path / "b.yaml"
    path.write_text(textwrap.dedent(f"""\
        behaviour: T
        performers: {{rex: {{model: mini}}}}
        routines: {{greet: {ROUTINES / 'greet.yaml'}, sit: {ROUTINES / 'sit.yaml'},
                    idle: {ROUTINES / 'idle.yaml'}}}
        """) + extra + "rules:\n" + textwrap.indent(textwrap.dedent(rules), "  "))
    stage, notes = Recorder(), []

    def emit(e: Event) -> None:
        if isinstance(e, BehaviourNote):
            notes.append(f"{e.t:g} {e.rule} {e.kind}: {e.text}")

    eng = Engine(load_behaviour(path), stage, emit=emit,
                 wall=lambda t: dt.datetime(2026, 1, 1, 8, 0) + dt.timedelta(seconds=t))
    eng.start(0.0)
    return eng, stage, notes


def plays(stage: Recorder) -> list[tuple[float, str]]:
    return [(t, r) for t, kind, r, _, _ in stage.calls if kind == "play"]


@pytest.mark.parametrize(("mode", "want"), [
    ("single", [(0, "greet")]),
    ("restart", [(0, "greet"), (1, "greet")]),
    ("parallel", [(0, "greet"), (1, "greet")]),
    ("queued", [(0, "greet"), (8.8, "greet")]),
])
def test_modes_when_a_rule_fires_during_its_run(
    tmp_path: Path, mode: str, want: list[tuple[float, str]]
) -> None:
    eng, stage, notes = engine_for(tmp_path, f"""\
        - {{name: g, mode: {mode}, when: [{{trigger: go}}], do: [{{play: greet}}]}}
        """, "triggers: [go]\n")
    eng.trigger("go", 0.0)
    eng.trigger("go", 1.0)
    last = stage.calls[-1]
    eng.routine_ended("rex", last[4], last[0] + 8.8 if mode != "restart" else 9.8, True)
    assert plays(stage) == want, notes


def test_safety_rule_preempts_and_lower_rule_is_refused(tmp_path: Path) -> None:
    eng, stage, notes = engine_for(tmp_path, """\
        - {name: low, safety: true, when: [{battery_below: 20}], do: [{play: sit}]}
        - {name: g, priority: 50, when: [{trigger: go}], do: [{play: greet}]}
        """, "triggers: [go]\n")
    eng.trigger("go", 0.0)
    eng.on_event(TelemetryRead(1.0, "rex", "battery", 10.0))
    eng.trigger("go", 2.0)
    assert plays(stage) == [(0, "greet"), (1, "sit")]
    assert "1 g cut: rex taken by rule low" in notes
    assert "2 g refused: rex is held by rule low (higher rank)" in notes


def test_hysteresis_fires_once_until_the_reading_clears(tmp_path: Path) -> None:
    eng, stage, _ = engine_for(tmp_path, """\
        - {name: low, mode: parallel, when: [{battery_below: 20, clear: 30}], do: [{stop: all}]}
        - {name: fall, mode: parallel, when: [{tilt_beyond: 60}], do: [{stop: all}]}
        """)
    for t, battery in enumerate([25, 19, 21, 19.5, 29, 18, 31, 19]):
        eng.on_event(TelemetryRead(float(t), "rex", "battery", battery))
    for t, roll in enumerate([10, 70, 40, 65, 20, -80], start=10):
        eng.on_event(TelemetryRead(float(t), "rex", "imu_roll", roll))
    rests = [t for t, kind, *_ in stage.calls if kind == "rest"]
    assert rests == [1, 7, 11, 15]


def test_offline_back_online_timers_and_sets(tmp_path: Path) -> None:
    eng, stage, notes = engine_for(tmp_path, """\
        - {name: gone, when: [{offline: 2}], do: [{publish: lost}, {switch: quiet}]}
        - {name: back, when: [{online: true}], do: [{switch: busy}]}
        - {name: tick, sets: [busy], mode: parallel, when: [{every: 3}, {at: "08:00:10"}],
           if: {time: {after: "07:00", before: "09:00"}}, do: [{play: idle}]}
        """, "sets: [busy, quiet]\ninitial: busy\n")
    eng.on_event(TelemetryRead(0.5, "rex", "battery", 80))
    assert eng.next_deadline() == 2.5  # offline; every 3 s would be at 3
    eng.advance(2.5)
    assert eng.next_deadline() is None  # the quiet set has no timers
    eng.on_event(TelemetryRead(6.0, "rex", "battery", 80))
    while (deadline := eng.next_deadline()) is not None and deadline < 12:
        eng.on_event(TelemetryRead(deadline, "rex", "battery", 80))
        eng.advance(deadline)
    assert "2.5 gone fired: rex offline (2 s without telemetry)" in notes
    assert "6 back fired: rex back online" in notes
    assert [t for t, _ in plays(stage)] == [9, 10]  # every 3 s from 6 (set re-entered), 08:00:10


def test_exhibition_rehearsal_trace(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    log = tmp_path / "run.jsonl"
    code = main(["behave", str(ROOT / "behaviours/exhibition/exhibition.yaml"), "--sim",
                 "--fast", "--script", str(ROOT / "behaviours/exhibition/rehearsal.yaml"),
                 "--log", str(log)])
    assert code == 0
    rules = [(r["t"], r["rule"], r["what"], r["text"]) for r in read_log(log)
             if r["kind"] == "rule"]
    assert (20.0, "fallen", "fired", "rex tilted 90 deg > 60") in rules
    assert (60.0, "evening-show", "fired", "at 19:00") in rules
    lines = [" ".join(line.split()) for line in capsys.readouterr().out.splitlines()]
    for want in [
        "0.00 rule idle: action: rex loops idle",
        "5.00 rule greet: action: rex plays greet",
        "5.00 rex: idle cut after 1.00 s: handed over to greet through the rest and default "
        "posture",
        "7.00 rule greet: skipped: trigger visitor: conditions do not hold",
        "13.80 rule greet: published: greeted",
        "20.00 rule fallen: fired: rex tilted 90 deg > 60",
        "21.00 rule fallen: action: rex plays get_up",
        "24.80 rule idle: action: rex loops idle",
        "60.00 rule evening-show: fired: at 19:00",
        "79.00 rule idle: fired: show ended on rex",
        "95.00 rule battery-low: action: rex set pace=slow",
        "95.00 rex: 1 frame(s) written beside idle",
        "95.00 rule battery-low: action: rex plays sit",
        "100.00 rule battery-low: action: switch to set resting",
        "110.00 rule charged: skipped: every 10 s: conditions do not hold",
    ]:
        assert want in lines, (want, lines)
