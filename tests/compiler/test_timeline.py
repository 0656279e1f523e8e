"""The timeline the plot and the HTML page draw (compiler/timeline.py), read back from
hand-made schedules: exactly which curves, events, colour runs and music grid a schedule's
frames give, without drawing anything (test_plot.py and test_timeline_html.py check what is
drawn)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from xgo_show.choreo.sections import Section
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.compiler.timeline import (
    Curve,
    Event,
    Lane,
    PerformerTimeline,
    Timeline,
    build_timeline,
    xgo_timeline,
)
from xgo_show.compiler.timeline_html import timeline_data, timeline_html, write_timeline_html
from xgo_show.diagnostics import Origin
from xgo_show.errors import FileAccessError
from xgo_show.profiles import get_profile
from xgo_show.profiles.xarm import position_to_degrees
from xgo_show.wire.xarm import ServoMove
from xgo_show.wire.xgo import write_frame

MINI = get_profile("mini")
RIDER = get_profile("rider")
NONE = ("", "")


def _at(line: int, cue: str) -> Origin:
    return Origin("show.yaml", line, 5, cue)


def _bytes(name: str, value: object, model: str = "mini") -> tuple[int, bytes]:
    reg = get_profile(model).register(name)
    if isinstance(value, float):
        return reg.address, bytes((reg.to_byte(value),))
    return reg.address, reg.encode_value(value)


def _write(t: float, origin: Origin | None, *fields: tuple[str, object], model: str = "mini",
           duration: float = 0.0) -> ScheduledFrame:
    """One write frame of consecutive registers, from the first one's address."""
    parts = [_bytes(name, value, model) for name, value in fields]
    return ScheduledFrame(t, write_frame(parts[0][0], b"".join(p[1] for p in parts)), origin,
                          duration)


def _value(name: str, value: float) -> float:
    """What the wire carries for ``value``: the decoded byte."""
    reg = MINI.register(name)
    decoded = reg.decode_value(bytes((reg.to_byte(value),)))
    assert isinstance(decoded, float)
    return decoded


def _performer(name: str, model: str, frames: list[ScheduledFrame], end: float
               ) -> PerformerSchedule:
    return PerformerSchedule(name, model, get_profile(model).link, tuple(frames), end)


def _schedule(*performers: PerformerSchedule, **settings: object) -> Schedule:
    return Schedule("the show", "show.yaml", performers, 50.0, **settings)  # type: ignore[arg-type]


def _initial(name: str) -> float:
    reg = MINI.register(name)
    assert reg.initial is not None
    value = reg.decode_value(reg.initial)
    assert isinstance(value, float)
    return value


def test_an_xgo_performers_registers_become_curves_from_their_initial_value() -> None:
    move, lean = _at(3, "rex: move a"), _at(7, "rex: move b")
    frames = [
        # Re-sent at its initial value only (a gap filler): no curve, and the others still.
        _write(0.2, move, ("body_x", _initial("body_x"))),
        _write(0.5, move, ("body_z", 100.0)),
        _write(1.0, lean, ("body_z", 110.0), ("roll", 5.0), ("pitch", -4.0)),
        _write(1.5, lean, ("roll", 6.0)),
        # Re-sent at its initial value only (a gap filler): no curve.
        _write(2.0, lean, ("body_x", _initial("body_x"))),
    ]
    rex = build_timeline(_schedule(_performer("rex", "mini", frames, 4.0))).performers[0]
    assert (rex.name, rex.model, rex.title) == ("rex", "mini", MINI.title)
    a, b = ("rex: move a", "show.yaml:3"), ("rex: move b", "show.yaml:7")
    # Lanes in the order of each unit's first register (body_z 0x35 mm, roll 0x36 deg), the
    # curves by address; each from t = 0 to the show's end, the last value held.
    assert rex.lanes == (
        Lane("mm", (Curve("body_z", "mm", (0.0, 0.5, 1.0, 4.0),
                          (_initial("body_z"), _value("body_z", 100.0),
                           _value("body_z", 110.0), _value("body_z", 110.0)),
                          sources=(NONE, a, b, b)),)),
        Lane("deg", (Curve("roll", "deg", (0.0, 1.0, 1.5, 4.0),
                           (_initial("roll"), _value("roll", 5.0), _value("roll", 6.0),
                            _value("roll", 6.0)), sources=(NONE, b, b, b)),
                     Curve("pitch", "deg", (0.0, 1.0, 4.0),
                           (_initial("pitch"), _value("pitch", -4.0), _value("pitch", -4.0)),
                           sources=(NONE, b, b)))),
    )
    assert rex.events == () and rex.colours == ()


def test_a_register_without_an_initial_value_starts_at_its_first_value_assumed() -> None:
    # A profile (a new robot's) whose body_z has no documented initial value and no unit.
    profile = replace(MINI, registers=tuple(
        replace(r, initial=None, unit="") if r.name == "body_z" else r for r in MINI.registers))
    frames = [_write(0.5, None, ("body_z", 100.0)), _write(1.0, None, ("body_z", 110.0))]
    rex = xgo_timeline(profile, _performer("rex", "mini", frames, 2.0), 2.0)
    first, second = _value("body_z", 100.0), _value("body_z", 110.0)
    assert rex.lanes == (Lane("value", (Curve(
        "body_z", "value", (0.0, 0.5, 1.0, 2.0), (first, first, second, second),
        known_from=0.5, sources=(NONE, NONE, NONE, NONE)),)),)


def test_lanes_follow_each_units_lowest_register_and_unitless_registers_share_one() -> None:
    # vx (0x30, mm/step) comes before body_z (0x35, mm) even when written later.
    frames = [_write(0.5, None, ("body_z", 100.0)), _write(1.0, None, ("vx", 10.0))]
    rex = build_timeline(_schedule(_performer("rex", "mini", frames, 2.0))).performers[0]
    assert [(lane.unit, [c.name for c in lane.curves]) for lane in rex.lanes] == [
        ("mm/step", ["vx"]), ("mm", ["body_z"])]
    assert [c.sources for lane in rex.lanes for c in lane.curves] == [
        (NONE, NONE, NONE), (NONE, NONE, NONE)]  # frames without an origin


def test_actions_and_settings_are_events_with_their_cue_by_start() -> None:
    frames = [
        _write(2.5, _at(9, "rex: set"), ("gait", "trot")),
        _write(1.0, _at(4, "rex: wave"), ("action", 13), duration=7.0),
        _write(3.0, None, ("action", 199), duration=1.5),
    ]
    rex = build_timeline(_schedule(_performer("rex", "mini", frames, 9.0))).performers[0]
    assert rex.events == (
        Event(1.0, 8.0, "action", "wave (action 13)", "show.yaml:4", "rex: wave"),
        Event(2.5, 2.5, "setting", "gait=trot", "show.yaml:9", "rex: set"),
        Event(3.0, 4.5, "action", "action 199"),
    )
    assert rex.lanes == ()


def test_led_colours_are_runs_from_each_change_to_the_next_by_led_then_start() -> None:
    red, also, blue, green = (_at(2, "red"), _at(3, "again"), _at(4, "blue"), _at(5, "green"))
    frames = [
        _write(0.0, red, ("led1", (255, 0, 0)), model="rider"),
        _write(0.2, green, ("led2", (0, 255, 16)), model="rider"),
        _write(0.5, also, ("led1", (255, 0, 0)), model="rider"),  # a resend: the same run
        _write(1.0, blue, ("led1", (0, 0, 255)), model="rider"),
        # A resend of led1's colour and a new one of led2 in one frame: led2's run starts.
        _write(2.0, green, ("led1", (0, 0, 255)), ("led2", (9, 9, 9)), model="rider"),
    ]
    rio = build_timeline(_schedule(_performer("rio", "rider", frames, 3.0))).performers[0]
    assert rio.colours == (
        Event(0.0, 1.0, "colour", "led1 #FF0000", "show.yaml:2", "red", "led1", (255, 0, 0)),
        Event(1.0, 3.0, "colour", "led1 #0000FF", "show.yaml:4", "blue", "led1", (0, 0, 255)),
        Event(0.2, 2.0, "colour", "led2 #00FF10", "show.yaml:5", "green", "led2", (0, 255, 16)),
        Event(2.0, 3.0, "colour", "led2 #090909", "show.yaml:5", "green", "led2", (9, 9, 9)),
    )
    assert rio.events == () and rio.lanes == ()


def test_an_arms_servos_ramp_over_each_move_and_are_assumed_before_their_first() -> None:
    first, second = _at(3, "arm: reach"), _at(8, "arm: grip")
    frames = [ScheduledFrame(0.5, ServoMove(1000, {6: 300, 1: 500}).encode(), first, 1.0),
              ScheduledFrame(2.0, ServoMove(500, {1: 700}).encode(), second, 0.5)]
    arm = build_timeline(_schedule(_performer("arm", "xarm", frames, 5.0))).performers[0]
    assert (arm.name, arm.model, arm.title) == ("arm", "xarm", get_profile("xarm").title)
    a, b = ("arm: reach", "show.yaml:3"), ("arm: grip", "show.yaml:8")
    d = position_to_degrees
    assert arm.lanes == (Lane("deg", (
        Curve("1 gripper", "deg", (0.0, 1.5, 2.0, 2.5, 5.0), (d(500), d(500), d(500), d(700),
              d(700)), ramp=True, known_from=1.5, sources=(NONE, a, b, b, NONE)),
        Curve("6 base", "deg", (0.0, 1.5, 5.0), (d(300), d(300), d(300)), ramp=True,
              known_from=1.5, sources=(NONE, a, NONE)),
    )),)
    assert arm.events == (Event(0.5, 1.5, "move", "move 1 gripper, 6 base", *a[::-1]),
                          Event(2.0, 2.5, "move", "move 1 gripper", *b[::-1]))
    assert arm.colours == ()
    # A servo with no name in the table, and an arm that never moves: no lane.
    odd = ScheduledFrame(0.0, ServoMove(0, {7: 500}).encode())
    arm = build_timeline(_schedule(_performer("arm", "xarm", [odd], 1.0))).performers[0]
    assert [c.name for c in arm.lanes[0].curves] == ["servo 7"]
    assert arm.lanes[0].curves[0].known_from == 0.0
    assert build_timeline(_schedule(_performer("arm", "xarm", [], 1.0))).performers[0].lanes == ()


def test_the_music_grid_bars_beats_tempo_and_sections() -> None:
    rex = _performer("rex", "mini", [], 5.0)
    sections = (Section("intro", 0.0), Section("verse", 2.0), Section("end", 4.5))
    timeline = build_timeline(_schedule(rex, bpm=120.0, beats_per_bar=4, sections=sections))
    assert (timeline.name, timeline.duration, timeline.tempo_text) == ("the show", 5.0,
                                                                       "120 bpm, 4/4")
    assert timeline.bars == ((0.0, 1), (2.0, 2), (4.0, 3))
    assert timeline.beats == (0.5, 1.0, 1.5, 2.5, 3.0, 3.5, 4.5, 5.0)
    assert timeline.sections == (("intro", 0.0, 2.0), ("verse", 2.0, 4.5), ("end", 4.5, 5.0))
    # A tempo change; 3/4 bars.
    changes = build_timeline(_schedule(rex, tempo_map=((1, 60.0, 3), (2, 120.0, 3))))
    assert changes.tempo_text == "60 bpm, 3/4 (+1 tempo change(s))"
    assert changes.bars == ((0.0, 1), (3.0, 2), (4.5, 3))
    assert changes.beats == (1.0, 2.0, 3.5, 4.0, 5.0)
    # Past 600 beats, bars only: 301 s at 120 bpm is 602 beats.
    long = build_timeline(_schedule(_performer("rex", "mini", [], 301.0), bpm=120.0))
    assert long.beats == () and len(long.bars) == 151 and long.bars[-1] == (300.0, 151)
    exactly = build_timeline(_schedule(_performer("rex", "mini", [], 300.0), bpm=120.0))
    assert len(exactly.beats) == 600 - 150 and exactly.bars[-1] == (300.0, 151)
    # No tempo: no grid; an empty show still lasts a millisecond (something to draw).
    plain = build_timeline(_schedule())
    assert (plain.duration, plain.bars, plain.beats, plain.tempo_text) == (0.001, (), (), "")


def _small() -> Timeline:
    curve = Curve("body_z", "mm", (0.0, 0.123456, 2.0), (97.5, 100.000049, 100.000049),
                  sources=(NONE, ("rex: up", "show.yaml:3"), ("rex: up", "show.yaml:3")))
    ramp = Curve("1 gripper", "deg", (0.0, 1.5, 2.0), (10.0, 10.0, 20.0), ramp=True,
                 known_from=1.5, sources=(NONE, ("arm: reach", "show.yaml:9"), NONE))
    rex = PerformerTimeline("rex", "mini", "XGO Mini", (Lane("mm", (curve,)),),
                            (Event(1.0, 8.0, "action", "wave (action 13)", "show.yaml:4",
                                   "rex: wave"),
                             Event(1.5, 1.5, "setting", "gait=trot"),
                             Event(1.6, 1.6, "setting", "pace=slow", "show.yaml:5"),
                             Event(1.7, 1.7, "setting", "gait=walk", "", "rex: walk")),
                            (Event(0.0, 2.0, "colour", "led1 #FF0000", "show.yaml:3",
                                   "rex: up", "led1", (255, 0, 0)),))
    arm = PerformerTimeline("arm", "xarm", "xArm", (Lane("deg", (ramp,)),), (), ())
    return Timeline("a </script> show", 2.0, (rex, arm), ((0.0, 1),), (0.5, 1.0, 1.5),
                    (("intro", 0.0, 2.0),), "120 bpm, 4/4")


def test_the_pages_data_has_short_keys_rounded_numbers_and_one_source_table() -> None:
    up = ["rex: up", "show.yaml:3"]
    assert timeline_data(_small()) == {
        "name": "a </script> show", "duration": 2.0, "tempo": "120 bpm, 4/4",
        "bars": [[0.0, 1]], "beats": [0.5, 1.0, 1.5], "sections": [["intro", 0.0, 2.0]],
        "performers": [
            {"name": "rex", "title": "XGO Mini",
             "lanes": [{"unit": "mm", "curves": [{
                 "name": "body_z", "t": [0.0, 0.1235, 2.0], "v": [97.5, 100.0, 100.0],
                 "ramp": False, "known": 0.0, "src": [-1, 0, 0]}]}],
             "events": [[1.0, 8.0, "action", "wave (action 13)", 1, "", None],
                        [1.5, 1.5, "setting", "gait=trot", -1, "", None],
                        [1.6, 1.6, "setting", "pace=slow", 2, "", None],
                        [1.7, 1.7, "setting", "gait=walk", 3, "", None]],
             "colours": [[0.0, 2.0, "colour", "led1 #FF0000", 0, "led1", [255, 0, 0]]]},
            {"name": "arm", "title": "xArm",
             "lanes": [{"unit": "deg", "curves": [{
                 "name": "1 gripper", "t": [0.0, 1.5, 2.0], "v": [10.0, 10.0, 20.0],
                 "ramp": True, "known": 1.5, "src": [-1, 4, -1]}]}],
             "events": [], "colours": []},
        ],
        "sources": [up, ["rex: wave", "show.yaml:4"], ["", "show.yaml:5"], ["rex: walk", ""],
                    ["arm: reach", "show.yaml:9"]],
    }


def test_the_page_holds_its_data_and_an_escaped_title(tmp_path: Path) -> None:
    page = timeline_html(_small())
    assert "<title>a &lt;/script&gt; show" in page
    assert "__TITLE__" not in page and "__DATA__" not in page
    # The data as compact JSON, "</" written "<\/" so it cannot end the script element.
    assert '{"name":"a <\\/script> show","duration":2.0,' in page
    assert page.count("</script>") == page.count("<script")
    schedule = _schedule(_performer("rex", "mini", [_write(0.5, None, ("body_z", 100.0))], 1.0))
    path = write_timeline_html(schedule, tmp_path / "t.html")
    assert path == tmp_path / "t.html"
    assert path.read_text(encoding="utf-8") == timeline_html(build_timeline(schedule))
    with pytest.raises(FileAccessError, match=r"^cannot write timeline .*missing.*t\.html: No such "
                       r"file or directory$"):
        write_timeline_html(schedule, tmp_path / "missing" / "t.html")
