"""Routines resolve to the IR the compiler consumes: times in seconds, physical values."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import check_file, load_show, resolve
from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, ResolvedShow, SetCue
from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import ChoreographyError

from .conftest import WriteFn

MINI = """
show: T
tempo: {bpm: 120}
performers:
  rex: {model: mini, port: /dev/ttyUSB0, arm: true}"""
RIDER = """
show: T
tempo: {bpm: 120}
performers:
  bob: {model: rider}"""
TEMPO_CHANGE = """
show: T
tempo: [{bar: 1, bpm: 120}, {bar: 3, bpm: 60, beats_per_bar: 3}]
performers:
  rex: {model: mini}"""  # 4/4 at 120 bpm for bars 1-2 (4 s), then 3/4 at 60 bpm


def cues(show: ResolvedShow, performer: str = "rex") -> tuple[object, ...]:
    return next(t for t in show.tracks if t.performer == performer).cues


def errors(path: Path) -> list[Diagnostic]:
    show, diags = check_file(path)
    assert show is None
    return [d for d in diags if d.is_error]


def test_show_settings_and_performer(write: WriteFn) -> None:
    path = write(MINI + """
settings: {control_rate: 100, gap_ms: 2, decimate: true, on_failure: continue,
           battery_floor: 30, end: "9.1"}
tracks:
  rex: [{action: stand_up}]
""")
    show = load_show(path)
    assert show.name == "T" and show.source == str(path)
    assert (show.control_rate, show.gap, show.decimate) == (100, 0.002, True)
    assert (show.on_failure, show.battery_floor, show.end) == ("continue", 30, 16.0)
    assert (show.bpm, show.beats_per_bar) == (120, 4)
    track = show.tracks[0]
    assert (track.performer, track.model, track.port) == ("rex", "mini", "/dev/ttyUSB0")


def test_action_cue_takes_profile_duration_and_origin(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {action: stand_up}
    - {action: 12, interrupt: true, beats: 2}
""")
    first, second = cues(load_show(path))
    assert first == ActionCue(0.0, first.origin, 2, "stand_up", 3.0)
    assert (first.origin.line, first.origin.column) == (7, 7)
    assert first.origin.file == str(path) and "action stand_up" in first.origin.cue
    assert isinstance(second, ActionCue)
    assert (second.start, second.action_id, second.name) == (3.0, 12, "sit_down")
    assert (second.duration, second.duration_given, second.interrupts) == (1.0, True, True)


def test_rider_action_needs_and_warns_about_a_given_duration(write: WriteFn) -> None:
    path = write(RIDER + """
tracks:
  bob:
    - {action: swinging, bars: 2}
""")
    show = load_show(path)
    (act,) = cues(show, "bob")
    assert isinstance(act, ActionCue) and act.duration == 4.0 and act.duration_given
    assert len(show.warnings) == 1 and "given by hand" in show.warnings[0].message


def test_move_timing_at_after_and_beats(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {at: 1, move: {body_z: 110, pitch: 10}, duration: 2}
    - {after: 0.5, move: {pitch: 0}, beats: 2}
    - {after: {beats: 1}, move: {body_z: 100}, bars: 1}
    - {at: "5.1", move: {roll: 5}, duration: 1}
    - {at: {bar: 6, beat: 2.5}, move: {roll: 0}, duration: 1}
""")
    a, b, c, d, e = cues(load_show(path))
    assert isinstance(a, MotionCue) and a.targets == {"body_z": 110, "pitch": 10}
    assert (a.start, a.duration) == (1.0, 2.0)
    assert isinstance(b, MotionCue) and (b.start, b.duration) == (3.5, 1.0)
    assert isinstance(c, MotionCue) and (c.start, c.duration) == (5.0, 2.0)
    assert isinstance(d, MotionCue) and d.start == 8.0
    assert isinstance(e, MotionCue) and e.start == 10.75


def test_multi_point_move_is_chained_segments(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - move: {roll: [10, -10, 0], pitch: 5}
      beats: 6
      limits: {roll: {velocity: 100}}
""")
    segs = cues(load_show(path))
    assert [s.start for s in segs] == [0.0, 1.0, 2.0]  # type: ignore[attr-defined]
    assert [s.targets for s in segs] == [  # type: ignore[attr-defined]
        {"roll": 10, "pitch": 5}, {"roll": -10}, {"roll": 0}
    ]
    first = segs[0]
    assert isinstance(first, MotionCue) and first.duration == 1.0
    assert first.limits["roll"].velocity == 100
    assert first.limits["roll"].jerk == 2000  # the rest comes from the profile


def test_open_ended_move_is_sequenced_by_its_minimum_time(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {move: {body_z: 120}}
    - {move: {body_z: 75}}
""")
    up, down = cues(load_show(path))
    assert isinstance(up, MotionCue) and up.duration is None
    # 97.5 mm (the 0x80 initial) -> 120 mm and back down 45 mm under 60 mm/s: at least 0.75 s.
    assert isinstance(down, MotionCue) and 0.375 < down.start < 2.0


def test_set_walk_periodic_and_gripper_arm(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {set: {gait: walk, pace: 2, imu_mode: stabilise}}
    - {walk: {vx: 10, vyaw: -20}, duration: 3}
    - {periodic: {roll: 3, z: 2}, duration: 2}
    - {gripper: 80, duration: 0.5}
    - {arm: {x: 100, z: 50}}
""")
    s, w0, w1, p0, p1, g, arm = cues(load_show(path))
    assert s == SetCue(0.0, s.origin, {"gait": "walk", "pace": 2, "imu_mode": "stabilise"})
    assert isinstance(w0, SetCue) and w0.values == {"vx": 10, "vyaw": -20}
    assert isinstance(w1, SetCue) and (w1.start, w1.values) == (3.0, {"vx": 0, "vyaw": 0})
    assert isinstance(p0, SetCue) and p0.values == {"periodic_roll": 3, "periodic_z": 2}
    assert isinstance(p1, SetCue) and (p1.start, p1.values) == (
        5.0, {"periodic_roll": 0, "periodic_z": 0}
    )
    assert isinstance(g, MotionCue) and (g.start, g.targets, g.duration) == (
        5.0, {"gripper": 80}, 0.5
    )
    assert isinstance(arm, MotionCue) and arm.targets == {"arm_x": 100, "arm_z": 50}


def test_led_set_and_fade(write: WriteFn) -> None:
    path = write(RIDER + """
tracks:
  bob:
    - {led: {all: red}}
    - {led: {led1: "#00ff80", led2: [1, 2, 3]}, fade: {beats: 2}}
    - {led: {led3: Warm White}}
""")
    s, f1, f2, s2 = cues(load_show(path), "bob")
    assert isinstance(s, SetCue) and s.values == {f"led{i}": (255, 0, 0) for i in range(1, 5)}
    assert f1 == FadeCue(0.0, f1.origin, "led1", (0, 255, 128), 1.0)
    assert f2 == FadeCue(0.0, f2.origin, "led2", (1, 2, 3), 1.0)
    assert isinstance(s2, SetCue) and s2.start == 1.0 and s2.values == {"led3": (255, 180, 100)}


def test_xarm_pose_and_pose_deg(write: WriteFn) -> None:
    path = write("""
show: T
performers:
  arm: {model: xarm}
tracks:
  arm:
    - {pose: {1: 500, 2: 300}, duration: 1}
    - {pose_deg: {3: 45, 4: -125}, duration: 2}
""")
    a, b = cues(load_show(path), "arm")
    assert a == ArmCue(0.0, a.origin, {1: 500, 2: 300}, 1.0)
    assert b == ArmCue(1.0, b.origin, {3: 680, 4: 0}, 2.0)


def test_phrases_with_parameters_and_relative_times(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  nod:
    params: {depth: 10, len: 1}
    cues:
      - {move: {pitch: $depth}, beats: $len}
      - {move: {pitch: -$depth}, beats: $len}
      - {at: "2.1", move: {pitch: 0}, duration: 0.5}
tracks:
  rex:
    - {at: 1, phrase: nod, with: {depth: 5}}
    - {phrase: nod}
""")
    c = cues(load_show(path))
    assert [(x.start, x.targets["pitch"]) for x in c] == [  # type: ignore[attr-defined]
        (1.0, 5), (1.5, -5), (3.0, 0), (3.5, 10), (4.0, -10), (5.5, 0)
    ]
    assert (c[0].origin.line, c[0].origin.column) == (9, 9)
    assert "phrase nod" in c[0].origin.cue


def test_repeat_blocks(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - repeat: 3
      cues:
        - {move: {roll: 5}, beats: 1}
        - {move: {roll: -5}, beats: 1}
    - {rest: {beats: 2}}
    - {move: {roll: 0}, beats: 1}
""")
    c = cues(load_show(path))
    assert len(c) == 7
    assert [x.start for x in c] == [0, 0.5, 1, 1.5, 2, 2.5, 4]


def test_includes_cues_and_phrase_libraries(write: WriteFn) -> None:
    write("""
- {move: {pitch: 5}, duration: 1}
- {phrase: shake}
""", "parts/intro.yaml")
    write("""
phrases:
  shake: {cues: [{move: {roll: [5, 0]}, duration: 1}]}
""", "lib/phrases.yaml")
    write("""
phrases:
  local: {cues: [{move: {yaw: 5}, duration: 1}]}
cues:
  - {phrase: local}
""", "parts/with_phrases.yaml")
    path = write(MINI + """
include: [lib/phrases.yaml]
tracks:
  rex:
    - {include: parts/intro.yaml}
    - {after: 1, include: parts/with_phrases.yaml}
    - {include: parts/intro.yaml}
""")
    c = cues(load_show(path))
    assert [x.start for x in c] == [0, 1, 1.5, 3, 4, 5, 5.5]
    assert Path(c[0].origin.file).name == "intro.yaml" and c[0].origin.line == 1


def test_tempo_map_converts_beats_across_changes(write: WriteFn) -> None:
    path = write(TEMPO_CHANGE + """
tracks:
  rex:
    - {at: "3.1", move: {pitch: 5}, beats: 1}
    - {at: 3.5, move: {yaw: 5}, beats: 2}
    - {at: "4.1", move: {roll: 5}, bars: 1}
""")
    b, a, c = cues(load_show(path))  # sorted by start time
    assert (a.start, a.duration) == (4.0, 1.0)  # type: ignore[attr-defined]
    assert b.duration == pytest.approx(1.5)  # type: ignore[attr-defined]
    assert (c.start, c.duration) == (7.0, 3.0)  # type: ignore[attr-defined]


def test_load_show_raises_with_every_problem(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {move: {body_z: 500}, duration: 1}
    - {action: nope}
    - {move: {pich: 3}, duration: 1}
""")
    with pytest.raises(ChoreographyError) as info:
        load_show(path)
    lines = [d.origin.line for d in info.value.diagnostics]  # type: ignore[attr-defined]
    assert lines == [7, 8, 9]
    assert "3 error(s)" in str(info.value)


def test_all_validation_errors_are_reported_together(write: WriteFn) -> None:
    path = write("""
show: T
settings: {control_rate: -1, on_failure: explode}
performers:
  rex: {model: mini, colour: red}
tracks:
  rex:
    - {move: {pitch: 5}, durration: 1}
    - {at: "x", action: wave}
""")
    found = {(d.origin.line, d.path) for d in errors(path) if d.origin}
    assert found == {
        (2, "settings.control_rate"),
        (2, "settings.on_failure"),
        (4, "performers.rex.colour"),
        (7, "tracks.rex[0].durration"),
        (8, "tracks.rex[1].at"),
    }


def test_phrase_errors_point_into_the_phrase_once(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  bad: {cues: [{move: {pitch: 99}, duration: 1}]}
tracks:
  rex: [{phrase: bad}, {phrase: bad}]
""")
    errs = errors(path)
    assert len(errs) == 1 and errs[0].origin is not None
    assert (errs[0].origin.line, errs[0].path) == (6, "phrases.bad.cues[0].move.pitch")


def test_warnings_do_not_fail(write: WriteFn) -> None:
    path = write(MINI + """
  ghost: {model: lite}
tracks:
  rex: [{set: {vx: 5}}, {at: 1, set: {vx: 0}}]
""")
    show = load_show(path)
    messages = [w.message for w in show.warnings]
    assert any("has no track" in m for m in messages)
    assert any("keeps the robot moving" in m for m in messages)


def test_interrupt_allows_cutting_actions_and_moves(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {action: stand_up}
    - {at: 1, move: {body_z: 100}, duration: 2, interrupt: true}
    - {at: 2, move: {body_z: 110}, duration: 1, interrupt: true}
""")
    assert len(cues(load_show(path))) == 3


def test_an_action_may_cut_a_running_move_only_on_purpose(write: WriteFn) -> None:
    cut = write(MINI + """
tracks:
  rex:
    - {walk: {vx: 10}, duration: 3}
    - {at: 1, action: wave}
""")
    with pytest.raises(ChoreographyError) as err:
        load_show(cut)
    messages = [d.message for d in err.value.diagnostics]
    # The action cuts the walk, and the walk's own stop at 3 s would cut the action.
    assert any("action 'wave' starts at 1.000 s while the cue at line 7" in m for m in messages)
    assert any("starts at 3.000 s while action 'wave'" in m for m in messages)
    on_purpose = write(MINI + """
tracks:
  rex:
    - {move: {pitch: 10}, duration: 2}
    - {at: 1, action: wave, interrupt: true}
""")
    assert len(cues(load_show(on_purpose))) == 2
    after = write(MINI + """
tracks:
  rex:
    - {move: {pitch: 10}, duration: 2}
    - {at: 2, action: wave}
""")
    assert len(cues(load_show(after))) == 2


def test_an_action_names_each_move_it_cuts_once(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {move: {pitch: 10, roll: 5, yaw: 3}, duration: 2}
    - {at: 0, walk: {vx: 5, vy: 2}, duration: 2}
    - {at: 1, action: wave, interrupt: false}
""")
    cut = [e for e in errors(path) if "action 'wave' starts at 1.000 s" in e.message]
    assert [e.message.split("while the cue at ")[1][:7] for e in cut] == ["line 7 ", "line 8 "]


def test_a_move_sent_with_an_action_is_cut_before_it_begins(write: WriteFn) -> None:
    # Same start time: whichever comes second in the track cuts the other.
    move_first = write(MINI + """
tracks:
  rex:
    - {at: 1, move: {pitch: 10}, duration: 2}
    - {at: 1, action: wave}
""")
    (err,) = errors(move_first)
    assert "action 'wave' starts at 1.000 s while the cue at line 7" in err.message
    action_first = write(MINI + """
tracks:
  rex:
    - {at: 1, action: wave}
    - {at: 1, move: {pitch: 10}, duration: 2}
""")
    (err,) = errors(action_first)
    assert "starts at 1.000 s while action 'wave'" in err.message


def test_a_fade_may_cut_a_fade_only_on_purpose(write: WriteFn) -> None:
    fades = """
tracks:
  bob:
    - {led: {led1: red}, fade: 2}
    - {at: 1, led: {led1: blue}, fade: 0.5%s}
"""
    with pytest.raises(ChoreographyError, match="led1 is already driven"):
        load_show(write(RIDER + fades % ""))
    show = load_show(write(RIDER + fades % ", interrupt: true"))
    (_, blue) = cues(show, "bob")
    assert isinstance(blue, FadeCue) and blue.interrupts


def test_led_writes_do_not_interrupt_actions(write: WriteFn) -> None:
    path = write(RIDER + """
tracks:
  bob:
    - {action: swinging, duration: 4}
    - {at: 1, led: {all: blue}, fade: 1}
""")
    assert len(cues(load_show(path), "bob")) == 5


def test_periodic_then_stop_then_direct_is_fine(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {periodic: {roll: 3}, duration: 4}
    - {move: {roll: 10}, duration: 1}
""")
    assert len(cues(load_show(path))) == 3


def test_yaml_booleans_for_on_off_choices(write: WriteFn) -> None:
    path = write(RIDER + """
tracks:
  bob: [{set: {steering_hold: off}}]
""")
    (s,) = cues(load_show(path), "bob")
    assert isinstance(s, SetCue) and s.values == {"steering_hold": "off"}


def test_runaway_repeat_is_refused(write: WriteFn, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(resolve, "MAX_CUES", 500)  # the real guard is 20 000: same code path
    path = write(MINI + """
tracks:
  rex:
    - repeat: 10000
      cues: [{repeat: 100, cues: [{set: {pace: slow}}]}]
""")
    assert any("more than 500 cues" in d.message for d in errors(path))


def test_cue_at_action_start_but_earlier_in_track_is_sent_first(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex:
    - {walk: {vx: 5}, duration: 1}
    - {action: stand_up}
    - {at: 4, action: sit_down}
    - {at: 4, move: {pitch: 5}, duration: 1}
""")
    errs = errors(path)
    assert len(errs) == 1 and errs[0].origin is not None and errs[0].origin.line == 10
    assert "while action 'sit_down'" in errs[0].message


def test_phrase_library_may_not_hold_cues(write: WriteFn) -> None:
    write("""
phrases: {a: {cues: [{rest: 1}]}}
cues: [{rest: 1}]
""", "lib.yaml")
    path = write(MINI + """
include: [lib.yaml]
tracks:
  rex: [{phrase: a}]
""")
    assert any("holds phrases only" in d.message for d in errors(path))


def test_duplicate_phrase_names_across_files(write: WriteFn) -> None:
    write("phrases: {a: {cues: [{rest: 1}]}}\n", "lib.yaml")
    path = write(MINI + """
include: [lib.yaml]
phrases: {a: {cues: [{rest: 2}]}}
tracks:
  rex: [{phrase: a}]
""")
    assert any("already defined" in d.message for d in errors(path))


def test_unquoted_off_is_a_colour_and_unused_phrases_warn(write: WriteFn) -> None:
    path = write(RIDER + """
phrases:
  spare: {cues: [{rest: 1}]}
tracks:
  bob: [{led: {all: off}}]
""")
    show = load_show(path)
    (s,) = cues(show, "bob")
    assert isinstance(s, SetCue) and s.values["led1"] == (0, 0, 0)
    assert [w.message for w in show.warnings] == ["phrase 'spare' is never played"]


def test_include_name_with_nul_is_an_error(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex: [{include: "a\\0b"}]
""")
    assert any("control character \\x00" in d.message for d in errors(path))


def test_cue_after_the_explicit_end_is_an_error(write: WriteFn) -> None:
    # Its frames would be sent after the end: an error (it was a warning, and they were sent).
    path = write(MINI + """
settings: {end: 2}
tracks:
  rex: [{action: stand_up}]
""")
    found = [d for d in errors(path) if "after the show's end" in d.message]
    assert found and found[0].origin is not None and found[0].origin.line == 7


def test_part_files_get_a_structural_check_only(write: WriteFn) -> None:
    ok = write("- {move: {pitch: 5}, duration: 1}\n", "part.yaml")
    show, diags = check_file(ok)
    assert show is None and [d.severity for d in diags] == ["warning"]
    assert "part file" in diags[0].message
    with pytest.raises(ChoreographyError, match="part file"):
        load_show(ok)
    bad = write("phrases: {a: {cues: [{rest: 1}]}}\ncues: [{mvoe: 1}]\n", "bad.yaml")
    _, diags = check_file(bad)
    assert [d.severity for d in diags] == ["warning", "error"]
    assert diags[1].origin is not None and diags[1].origin.line == 2


@pytest.mark.parametrize("register", ["gait", "periodic_roll", "mark_time"])
def test_only_trajectory_registers_move(write: WriteFn, register: str) -> None:
    path = write(MINI + f"""
tracks:
  rex:
    - move: {{{register}: 2}}
      limits: {{{register}: {{velocity: 1, acceleration: 1, jerk: 1}}}}
      duration: 1
""")
    assert any("cannot be moved smoothly" in d.message for d in errors(path))


def test_resolved_show_carries_the_tempo_map(write: WriteFn) -> None:
    path = write(TEMPO_CHANGE + """
tracks:
  rex: [{action: stand_up}]
""")
    show = load_show(path)
    assert show.tempo_map == ((1, 120.0, 4), (3, 60.0, 3))
    assert (show.bpm, show.beats_per_bar) == (120.0, 4)
    tempo = TempoMap([Segment(*row) for row in show.tempo_map])
    assert tempo.position(4, 1) == 7.0
