"""Rehearsing a behaviour from a timed script on virtual time, in-process: the script's
refusals at file:line:col, and the trace word for word (what the script does to the robots,
what each rule decided, what each virtual robot did and when), with the telemetry every
quarter second, routine ends at each performer's own length, the start's wall-clock time and
the script's last instant. Two performers (rex, a Mini; ada, a Rider) and one-move routines
of known lengths, so that every time in a trace can be counted by hand."""

from __future__ import annotations

import datetime as dt
import textwrap
from pathlib import Path

import pytest

from tests.behave.conftest import write_behaviour
from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.loader import Behaviour
from xgo_show.behave.rehearsal import (
    TELEMETRY_INTERVAL,
    RehearsalScript,
    VirtualStage,
    load_rehearsal,
    rehearse,
)
from xgo_show.errors import ChoreographyError
from xgo_show.runtime.events import Event, EventBus, TelemetryRead

# Each routine's parts and their lengths in seconds.
ROUTINES = {
    "one": {"rex": 1.5},
    "duo": {"rex": 1.0, "ada": 2.0},
}


def behaviour(tmp_path: Path, rules: str, extra: str = "triggers: [go]\n") -> Behaviour:
    return load_behaviour(write_behaviour(tmp_path, ROUTINES, rules, extra))


def script(tmp_path: Path, text: str, b: Behaviour) -> RehearsalScript:
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent(text))
    return load_rehearsal(path, b)


def trace(b: Behaviour, s: RehearsalScript, events: EventBus | None = None) -> list[str]:
    lines: list[str] = []
    rehearse(b, s, lambda t, line: lines.append(f"{t:g} {line}"), events)
    return lines


def test_a_script_played_word_for_word(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}, {publish: done}]}
        - {name: low, when: [{battery_below: 20}],
           do: [{set: {pace: slow}, performers: [rex]}, {play: one}]}
        - {name: ended, when: [{routine_ended: one}], do: [{publish: rested}]}
        """)
    s = script(tmp_path, """\
        duration: 6
        events:
          - {at: 1, trigger: go}
          - {at: 3.5, performer: rex, battery: 12.5}
        """, b)
    assert trace(b, s) == [
        "1 script: trigger go",
        "1 rule g: fired: trigger go",
        "1 rule g: action: rex, ada plays duo",
        # rex's part ends at 2, ada's at 3: the rule goes on when the last one ends
        "3 rule g: published: done",
        "3.5 script: rex battery 12.5%",
        "3.5 rule low: fired: rex battery 12% < 20%",
        "3.5 rule low: action: rex set pace=slow",
        "3.5 rex: 1 frame(s) written beside nothing",
        "3.5 rule low: action: rex plays one",
        "5 rule ended: fired: one ended on rex",
        "5 rule ended: published: rested",
    ]


def test_a_routine_cut_says_how_long_it_played_and_how_it_ended(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        - {name: low, when: [{battery_below: 20}],
           do: [{set: {pace: slow}, performers: [rex]}, {play: one, performers: [rex]}]}
        - {name: fall, safety: true, when: [{tilt_beyond: 60}], do: [{safe_stop: [rex]}]}
        - {name: hush, when: [{trigger: hush}], do: [{stop: [ada]}]}
        """, "triggers: [go, hush]\n")
    s = script(tmp_path, """\
        duration: 5
        events:
          - {at: 0.5, trigger: go}
          - {at: 0.75, trigger: hush}
          - {at: 1.0, performer: rex, battery: 10}
          - {at: 1.3, performer: rex, fall: true}
        """, b)
    assert trace(b, s) == [
        "0.5 script: trigger go",
        "0.5 rule g: fired: trigger go",
        "0.5 rule g: action: rex, ada plays duo",
        "0.75 script: trigger hush",
        "0.75 rule hush: fired: trigger hush",
        "0.75 rule hush: action: ada rest",
        "0.75 ada: duo cut after 0.25 s: rest",
        "1 script: rex battery 10%",
        "1 rule low: fired: rex battery 10% < 20%",
        "1 rule low: action: rex set pace=slow",
        "1 rex: 1 frame(s) written beside duo",
        "1 rule g: cut: rex taken by rule low",
        "1 rule low: action: rex plays one",
        "1 rex: duo cut after 0.50 s: handed over to one through the rest and default posture",
        "1.3 script: rex falls over",
        # the fall is seen at the next telemetry, a quarter second on the grid
        "1.5 rule fall: fired: rex tilted 90 deg > 60",
        "1.5 rule fall: action: rex safe stop",
        "1.5 rex: one cut after 0.50 s: safe stop (rule fall)",
    ]


def test_telemetry_every_quarter_second_while_online_and_the_fall_as_90_deg(
    tmp_path: Path,
) -> None:
    b = behaviour(tmp_path, """\
        - {name: tilt, mode: parallel, when: [{tilt_beyond: 0.5, clear: 0.25}],
           do: [{publish: tilted}]}
        - {name: gone, when: [{offline: 0.6, performers: [ada]}], do: [{publish: lost}]}
        - {name: back, when: [{online: true, performers: [ada]}], do: [{publish: found}]}
        """, "")
    s = script(tmp_path, """\
        start: "08:00"
        duration: 4
        events:
          - {at: 0.6, performer: rex, fall: true}
          - {at: 1.1, performer: rex, recover: true}
          - {at: 1.3, performer: ada, offline: true}
          - {at: 2.1, performer: rex, fall: true}
          - {at: 3.1, performer: ada, online: true}
        """, b)
    bus, seen = EventBus(), list[Event]()
    bus.subscribe(seen.append)
    assert trace(b, s, bus) == [
        "0.6 script: rex falls over",
        "0.75 rule tilt: fired: rex tilted 90 deg > 0.5",
        "0.75 rule tilt: published: tilted",
        "1.1 script: rex is back on its feet",
        "1.3 script: ada goes offline",
        # last heard at 1.25: offline 0.6 s later; back at the first reading after 3.1
        "1.85 rule gone: fired: ada offline (0.6 s without telemetry)",
        "1.85 rule gone: published: lost",
        # on its feet again since the reading at 1.25 (the trigger re-armed): a second fall
        "2.1 script: rex falls over",
        "2.25 rule tilt: fired: rex tilted 90 deg > 0.5",
        "2.25 rule tilt: published: tilted",
        "3.1 script: ada comes back online",
        "3.25 rule back: fired: ada back online",
        "3.25 rule back: published: found",
    ]
    assert all(isinstance(e, BehaviourNote) for e in seen)
    assert [f"{e.t:g} {e.rule} {e.kind}" for e in seen if isinstance(e, BehaviourNote)] == [
        "0.75 tilt fired", "0.75 tilt published", "1.85 gone fired", "1.85 gone published",
        "2.25 tilt fired", "2.25 tilt published", "3.25 back fired", "3.25 back published"]


def test_the_virtual_robots_readings(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        """)
    stage = VirtualStage(b, 42.5, lambda t, line: None)
    stage.robots["rex"].fallen = True
    stage.robots["ada"].online = False
    assert stage.telemetry(2.5) == [
        TelemetryRead(2.5, "rex", "battery", 42.5),
        TelemetryRead(2.5, "rex", "imu_roll", 90.0),
        TelemetryRead(2.5, "rex", "imu_pitch", 0.0),
    ]
    stage.robots["ada"].online = True
    assert stage.telemetry(3.0)[3:] == [
        TelemetryRead(3.0, "ada", "battery", 42.5),
        TelemetryRead(3.0, "ada", "imu_roll", 0.0),
        TelemetryRead(3.0, "ada", "imu_pitch", 0.0),
    ]
    assert TELEMETRY_INTERVAL == 0.25


def test_the_script_battery_default_and_a_given_one(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: low, when: [{battery_below: 80.5}], do: [{publish: low}]}
        """, "")
    assert trace(b, script(tmp_path, "duration: 0.25\n", b)) == [
        "0.25 rule low: fired: rex battery 80% < 80.5%",
        "0.25 rule low: published: low",
        "0.25 rule low: fired: ada battery 80% < 80.5%",
        "0.25 rule low: published: low",
    ]
    assert trace(b, script(tmp_path, "duration: 1\nbattery: 81\n", b)) == []


def test_a_loop_plays_again_at_each_end_until_taken(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: idle, when: [{startup: true}], do: [{loop: one}]}
        - {name: g, when: [{trigger: go}], do: [{play: one}]}
        - {name: ended, mode: parallel, when: [{routine_ended: one}], do: [{publish: ended}]}
        """)
    s = script(tmp_path, """\
        duration: 5
        events:
          - {at: 3.5, trigger: go}
        """, b)
    # the loop plays again at 1.5 and 3 (it has played 0.5 s when taken); its end due at 4.5
    # is stale once go takes rex, and a loop's ends fire no routine_ended
    assert trace(b, s) == [
        "0 rule idle: fired: start-up",
        "0 rule idle: action: rex loops one",
        "3.5 script: trigger go",
        "3.5 rule g: fired: trigger go",
        "3.5 rule g: action: rex plays one",
        "3.5 rex: one cut after 0.50 s: handed over to one through the rest and default posture",
        "5 rule ended: fired: one ended on rex",
        "5 rule ended: published: ended",
    ]


def test_script_events_come_before_timers_due_at_the_same_instant_and_the_last_instant_counts(
    tmp_path: Path,
) -> None:
    b = behaviour(tmp_path, """\
        - {name: tick, mode: parallel, when: [{every: 1}], do: [{publish: tick}]}
        - {name: g, mode: parallel, when: [{trigger: go}], do: [{publish: went}]}
        """)
    s = script(tmp_path, """\
        duration: 2
        events:
          - {at: 1, trigger: go}
          - {at: 2, trigger: go}
        """, b)
    assert trace(b, s) == [
        "1 script: trigger go",
        "1 rule g: fired: trigger go",
        "1 rule g: published: went",
        "1 rule tick: fired: every 1 s",
        "1 rule tick: published: tick",
        "2 script: trigger go",
        "2 rule g: fired: trigger go",
        "2 rule g: published: went",
        "2 rule tick: fired: every 1 s",
        "2 rule tick: published: tick",
    ]


def test_a_timer_just_past_the_end_is_left_out(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: tick, mode: parallel, when: [{every: 1.5}], do: [{publish: tick}]}
        """, "")
    s = script(tmp_path, "duration: 2.9\n", b)
    assert trace(b, s) == ["1.5 rule tick: fired: every 1.5 s", "1.5 rule tick: published: tick"]


@pytest.mark.parametrize(("start", "fired"), [
    ("08:00", "3"), ("07:59:58", "5"), ("08:00:02", "1"),
])
def test_the_start_is_the_wall_clock_time_at_zero(
    tmp_path: Path, start: str, fired: str
) -> None:
    b = behaviour(tmp_path, """\
        - {name: at, when: [{at: "08:00:03"}], do: [{publish: now}]}
        """, "")
    s = script(tmp_path, f"start: '{start}'\nduration: 6\n", b)
    assert trace(b, s)[0] == f"{fired} rule at: fired: at 08:00:03"


def test_the_start_defaults_to_noon(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: at, when: [{at: "12:00:01"}], do: [{publish: now}]}
        """, "")
    assert trace(b, script(tmp_path, "duration: 2\n", b))[0] == "1 rule at: fired: at 12:00:01"


def test_rehearse_hands_back_the_engine_as_the_script_left_it(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        """)
    s = script(tmp_path, "duration: 1.5\nevents: [{at: 0.5, trigger: go}]\n", b)
    engine = rehearse(b, s, lambda t, line: None)
    assert (engine.playing("rex"), engine.playing("ada")) == (None, "duo")
    assert engine.wall(0.0) == dt.datetime(2026, 1, 1, 12, 0)
    assert engine.wall(90.5) == dt.datetime(2026, 1, 1, 12, 1, 30, 500000)


def test_writes_go_only_to_the_actions_performers(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: one}, {set: {body_z: 100}}]}
        """)
    stage_lines: list[str] = []
    stage = VirtualStage(b, 80.0, lambda t, line: stage_lines.append(f"{t:g} {line}"))
    stage.play("one", ("rex",), 7, 1.0)
    stage.write("g.do[1]", ("rex",), 1.25)
    stage.write("g.do[1]", ("ada",), 1.5)
    stage.write("g.do[1]", (), 1.75)
    assert stage_lines == ["1.25 rex: 1 frame(s) written beside one",
                           "1.5 ada: 1 frame(s) written beside nothing"]
    assert [(i.t, i.seq) for i in stage._queue] == [(2.5, 0)]


ONE_OF = "give exactly one of trigger, fall, recover, battery, offline, online"
SCRIPT_CASES = [
    # (name, script text, the error after the file's path)
    ("two_cues", "duration: 1\nevents:\n  - {at: 1, trigger: go, performer: rex, fall: true}\n",
     f"3:5: error: events[0]: {ONE_OF}"),
    ("no_cue", "duration: 1\nevents:\n  - {at: 1, performer: rex}\n",
     f"3:5: error: events[0]: {ONE_OF}"),
    ("no_performer", "duration: 1\nevents:\n  - {at: 1, battery: 10}\n",
     "3:5: error: events[0]: battery: needs performer:"),
    ("unknown_performer", "duration: 1\nevents:\n  - {at: 1, performer: bob, fall: true}\n",
     "3:24: error: events[0].performer: no performer 'bob'"),
    ("unknown_trigger", "duration: 1\nevents:\n  - {at: 1, trigger: gone}\n",
     "3:22: error: events[0].trigger: no rule waits for trigger 'gone'"),
    ("negative_at", "duration: 1\nevents:\n  - {at: -1, trigger: go}\n",
     "3:10: error: events[0].at: -1 s is too small: give 0 s or more"),
    ("battery_over", "duration: 1\nevents:\n  - {at: 1, performer: rex, battery: 101}\n",
     "3:38: error: events[0].battery: 101 is too large: give 0 to 100"),
    ("zero_duration", "duration: 0\n",
     "1:11: error: duration: 0 s is too small: give more than 0 and at most 86400 s"),
    ("day_and_more", "duration: 86401\n",
     "1:11: error: duration: 86401 s is too large: give more than 0 and at most 86400 s"),
    ("script_battery", "duration: 1\nbattery: -1\n",
     "2:10: error: battery: -1 is too small: give 0 to 100"),
    ("unknown_field", "duration: 1\nspeed: 2\n",
     "2:1: error: speed: unknown field 'speed' (allowed: start, duration, battery, events)"),
    ("bad_start", "start: '25:00'\nduration: 1\n",
     "1:8: error: start: should be a value in the expected form, not '25:00'"),
    ("not_yaml", "duration: [1\n", "2:1: error: YAML syntax: while parsing a flow sequence, "
     "expected ',' or ']', but got '<stream end>'"),
]


@pytest.mark.parametrize("case", SCRIPT_CASES, ids=[c[0] for c in SCRIPT_CASES])
def test_a_bad_script_is_refused_at_its_place(
    tmp_path: Path, case: tuple[str, str, str]
) -> None:
    name, text, error = case
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        """)
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    with pytest.raises(ChoreographyError) as err:
        load_rehearsal(path, b)
    assert str(err.value).splitlines() == [f"{path}: not a rehearsal script:", f"{path}:{error}"]
    assert len(err.value.diagnostics) == 1


def test_a_script_with_several_bad_names_lists_each(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        """)
    path = tmp_path / "s.yaml"
    path.write_text("duration: 1\nevents:\n  - {at: 1, trigger: gone}\n"
                    "  - {at: 2, performer: bob, fall: true}\n  - {at: 3, trigger: go}\n")
    with pytest.raises(ChoreographyError) as err:
        load_rehearsal(path, b)
    assert str(err.value).splitlines()[1:] == [
        f"{path}:3:22: error: events[0].trigger: no rule waits for trigger 'gone'",
        f"{path}:4:24: error: events[1].performer: no performer 'bob'",
    ]


def test_a_time_window_is_read_on_the_wall_clock_as_the_script_goes_on(tmp_path: Path) -> None:
    b = behaviour(tmp_path, """\
        - {name: g, mode: parallel, when: [{trigger: go}], if: {time: {after: "08:00"}},
           do: [{publish: went}]}
        """)
    s = script(tmp_path, """\
        start: "07:59:30"
        duration: 60
        events: [{at: 10, trigger: go}, {at: 40, trigger: go}]
        """, b)
    assert trace(b, s) == [
        "10 script: trigger go",
        "10 rule g: skipped: trigger go: conditions do not hold",
        "40 script: trigger go",
        "40 rule g: fired: trigger go",
        "40 rule g: published: went",
    ]


def test_a_robot_cut_is_said_once_and_a_stale_end_leaves_the_routine_playing(
    tmp_path: Path,
) -> None:
    b = behaviour(tmp_path, """\
        - {name: idle, when: [{startup: true}], do: [{loop: one}]}
        - {name: g, when: [{trigger: go}], do: [{play: one}]}
        - {name: hush, mode: parallel, when: [{trigger: hush}], do: [{stop: [rex]}]}
        """, "triggers: [go, hush]\n")
    s = script(tmp_path, """\
        duration: 6
        events:
          - {at: 3.5, trigger: go}
          - {at: 4.75, trigger: hush}
          - {at: 4.9, trigger: hush}
        """, b)
    # the loop's end due at 4.5 is stale: at 4.75 rex still plays g's one (from 3.5), and at
    # 4.9 (before that one's end was due) there is nothing left to cut
    assert trace(b, s)[6:] == [
        "4.75 script: trigger hush",
        "4.75 rule hush: fired: trigger hush",
        "4.75 rule hush: action: rex rest",
        "4.75 rex: one cut after 1.25 s: rest",
        "4.9 script: trigger hush",
        "4.9 rule hush: fired: trigger hush",
        "4.9 rule hush: action: rex rest",
    ]
