"""compile_show and compile_diagnostics (compiler/build.py) on small hand-made shows: what a
schedule carries over from the show, each performer's link, gap and end, the errors and
warnings word for word, each once, and validate's short cut agreeing with the compile."""

from __future__ import annotations

import pytest

from tests.compiler.conftest import origin
from xgo_show.choreo.music import Music
from xgo_show.choreo.resolved import ArmCue, Cue, MotionCue, ResolvedShow, ResolvedTrack, SetCue
from xgo_show.choreo.sections import Section
from xgo_show.compiler import compile_diagnostics, compile_show
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import CompileError
from xgo_show.profiles import Link, get_profile

MINI = get_profile("mini")
# Twelve registers moving at once: more link time than a 1000 Hz tick has.
DENSE = ("vx", "body_x", "body_y", "body_z", "roll", "pitch", "yaw", "leg1_x", "leg1_y",
         "leg1_z", "leg2_x", "leg2_z")


def _dense(start: float = 0.0, name: str = "m", line: int = 1, to: float = 0.7) -> MotionCue:
    targets = {}
    for reg_name in DENSE:
        reg = MINI.register(reg_name)
        assert reg.minimum is not None and reg.maximum is not None
        targets[reg_name] = reg.minimum + (reg.maximum - reg.minimum) * to
    return MotionCue(start, origin(name, line), targets, 3.0)


def _show(tracks: dict[str, tuple[str, list[Cue]]], **settings: object) -> ResolvedShow:
    resolved = tuple(ResolvedTrack(name, model, tuple(sorted(cues, key=lambda c: c.start)))
                     for name, (model, cues) in tracks.items())
    return ResolvedShow("s", "show.yaml", resolved, **settings)  # type: ignore[arg-type]


def _both(show: ResolvedShow) -> tuple[str, tuple[Diagnostic, ...]]:
    """The error both compile_show and compile_diagnostics raise (they must agree)."""
    with pytest.raises(CompileError) as full:
        compile_show(show)
    with pytest.raises(CompileError) as quick:
        compile_diagnostics(show)
    assert (str(quick.value), quick.value.diagnostics) == (str(full.value),
                                                           full.value.diagnostics)
    return str(full.value), full.value.diagnostics


def test_the_slowest_control_rate_compiles() -> None:
    show = _show({"rex": ("mini", [MotionCue(0.0, origin("m"), {"body_z": 100.0}, 2.0)])},
                 control_rate=1.0)
    assert [f.t for f in compile_show(show).performers[0].frames] == [0.0, 1.0, 2.0]


@pytest.mark.parametrize("rate", [0.0, -5.0])
def test_a_control_rate_must_be_positive(rate: float) -> None:
    show = _show({"rex": ("mini", [])}, control_rate=rate)
    for compile_fn in (compile_show, compile_diagnostics):
        with pytest.raises(CompileError, match=rf"^control_rate must be positive, not {rate:g} "
                           r"Hz$"):
            compile_fn(show)


def test_every_performers_errors_are_gathered_counted_and_raised_together() -> None:
    unknown = _show({"a": ("nosuch", []), "rex": ("mini", [MotionCue(0.0, origin("g", 4),
                                                                      {"gait": 1.0})])})
    text, diags = _both(unknown)
    assert [(d.severity, d.origin and d.origin.line, d.path) for d in diags] == [
        ("error", None, "tracks.a"), ("error", 4, "tracks.rex")]
    assert "nosuch" in diags[0].message
    assert diags[1].message == "cue 'g': gait cannot follow a trajectory"
    assert text == ("show 's' cannot be compiled (2 errors):\n"
                    + "\n".join(d.format() for d in diags))
    text, diags = _both(_show({"a": ("nosuch", [])}))
    assert text == f"show 's' cannot be compiled (1 error):\n{diags[0].format()}"
    # The same problem met twice at one place (a repeat, a shared phrase): once.
    twice = _show({"rex": ("mini", [MotionCue(0.0, origin("g", 4), {"gait": 1.0}),
                                    MotionCue(1.0, origin("g", 4), {"gait": 2.0})])})
    assert len(_both(twice)[1]) == 1


def test_a_schedule_carries_the_shows_settings_and_each_performers_link() -> None:
    sections = (Section("intro", 0.0), Section("verse", 1.0))
    loader = Diagnostic("warning", "a loader's finding", origin("w", 2), "tracks.rex")
    show = ResolvedShow(
        "s", "show.yaml",
        (ResolvedTrack("rex", "mini", (SetCue(0.0, origin("set"), {"gait": "trot"}),),
                       port="/dev/ttyUSB3"),
         ResolvedTrack("arm", "xarm", (ArmCue(0.5, origin("r"), {1: 500}, 1.0),))),
        control_rate=40.0, gap=0.005, on_failure="continue", battery_floor=35, bpm=90.0,
        beats_per_bar=3, warnings=(loader,), tempo_map=((1, 90.0, 3),), sections=sections,
        music=Music("song.ogg", "/music/song.ogg", -1.5))
    schedule = compile_show(show)
    assert (schedule.name, schedule.source, schedule.control_rate, schedule.on_failure,
            schedule.battery_floor, schedule.bpm, schedule.beats_per_bar, schedule.tempo_map,
            schedule.sections, schedule.music, schedule.warnings) == (
        "s", "show.yaml", 40.0, "continue", 35, 90.0, 3, ((1, 90.0, 3),), sections,
        Music("song.ogg", "/music/song.ogg", -1.5), (loader,))
    rex, arm = schedule.performers
    assert (rex.name, rex.model, rex.port, arm.name, arm.model, arm.port) == (
        "rex", "mini", "/dev/ttyUSB3", "arm", "xarm", None)
    assert rex.link == Link(MINI.link.baud, 0.005, MINI.link.bits_per_byte)
    xarm = get_profile("xarm")
    assert arm.link == Link(xarm.link.baud, 0.005, xarm.link.bits_per_byte)
    assert compile_diagnostics(show) == (loader,)
    # Without a gap of its own, each performer's profile's.
    default = compile_show(ResolvedShow("s", "show.yaml", show.tracks))
    assert [p.link for p in default.performers] == [MINI.link, xarm.link]
    # The frames at their paced start, labelled from their bytes.
    assert [(f.t, f.label, f.origin) for f in rex.frames] == [(0.0, "gait=trot",
                                                               origin("set"))]
    assert [(f.t, f.duration) for f in arm.frames] == [(0.5, 1.0)]


def test_a_performers_part_ends_at_the_shows_end_or_its_last_frame() -> None:
    move = MotionCue(0.0, origin("m"), {"body_z": 100.0}, 1.0)
    assert compile_show(_show({"rex": ("mini", [move])})).performers[0].end == 1.0
    assert compile_show(_show({"rex": ("mini", [move])}, end=4.0)).performers[0].end == 4.0
    # An end before the last frame has gone out: the last frame's start.
    late = compile_show(_show({"rex": ("mini", [move])}, end=0.5)).performers[0]
    assert late.end == late.frames[-1].t > 0.5


def test_a_link_that_does_not_fit_names_the_cue_the_times_and_the_way_out() -> None:
    _, diags = _both(_show({"rex": ("mini", [_dense(), _dense(4.0, "n", 7, 0.3)])},
                              control_rate=1000.0))
    # One error a cue, however many of its frames are late.
    assert [(d.severity, d.origin and d.origin.cue, d.path) for d in diags] == [
        ("error", "m", "tracks.rex"), ("error", "n", "tracks.rex")]
    assert diags[0].message == (
        "the link does not fit cue 'm': its frame planned at 0.000 s could only start at "
        "0.003 s, more than one control period (1 ms) late at 115200 baud with 1.2 ms between "
        "frames; write fewer registers at once or lower control_rate, or set decimate: true")
    assert diags[1].message.startswith("the link does not fit cue 'n': its frame planned at 4.")
    # Ten minutes in: times to the millisecond.
    _, diags = _both(_show({"rex": ("mini", [_dense(600.0)])}, control_rate=1000.0))
    assert diags[0].message.startswith(
        "the link does not fit cue 'm': its frame planned at 600.000 s could only start at "
        "600.003 s,")
    # With decimate, the samples give way; settings cannot: no hint to decimate then.
    crowded: list[Cue] = [SetCue(0.0, origin("names"), {"bt_name": "a" * 20, "gait": "trot"})]
    _, diags = _both(_show({"rex": ("mini", crowded)}, control_rate=1000.0, decimate=True,
                              gap=0.002))
    assert [d.message for d in diags] == [
        "the link does not fit cue 'names': its frame planned at 0.000 s could only start at "
        "0.003 s, more than one control period (1 ms) late at 115200 baud with 2 ms between "
        "frames; write fewer registers at once or lower control_rate"]


def test_decimated_samples_are_a_warning_with_their_count_and_first_drop() -> None:
    show = _show({"rex": ("mini", [_dense()])}, control_rate=1000.0, decimate=True)
    warnings = compile_show(show).warnings
    assert compile_diagnostics(show) == warnings
    assert [(d.severity, d.origin, d.path, d.message) for d in warnings] == [(
        "warning", origin("m"), "tracks.rex",
        "decimated 179 of 426 trajectory sample frames to fit the link (first at 0.000 s); "
        "their values went out with later frames")]
    assert compile_show(_show({"rex": ("mini", [_dense()])}, control_rate=50.0,
                              decimate=True)).warnings == ()
    later = compile_show(_show({"rex": ("mini", [_dense(600.0)])}, control_rate=1000.0,
                               decimate=True)).warnings
    assert "(first at 600.000 s)" in later[0].message


def test_validate_only_walks_a_performer_whose_link_provably_fits(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The short cut (compiler/linkfit.py) neither samples moves nor paces frames: with the
    # sampling broken, validate still answers for a show that fits, and only the compile fails.
    from xgo_show.compiler import planner

    def broken(self: object, run: object) -> None:
        raise AssertionError("sampled")

    show = _show({"rex": ("mini", [MotionCue(0.0, origin("m"), {"body_z": 100.0}, 1.0),
                                   MotionCue(1.0, origin("g", 4), {"gait": 1.0})])})
    monkeypatch.setattr(planner.XgoPlanner, "_sample_run", broken)
    with pytest.raises(CompileError, match="gait cannot follow a trajectory"):
        compile_diagnostics(show)
    with pytest.raises(AssertionError, match="sampled"):
        compile_show(show)


def test_validate_goes_on_after_a_performer_it_proved_fits() -> None:
    # rex fits its link (only walked); max after it still has its error found.
    show = _show({"rex": ("mini", [MotionCue(0.0, origin("m"), {"body_z": 100.0}, 1.0)]),
                  "max": ("mini", [MotionCue(0.0, origin("g", 4), {"gait": 1.0})])})
    _, diags = _both(show)
    assert [(d.path, d.message) for d in diags] == [
        ("tracks.max", "cue 'g': gait cannot follow a trajectory")]


def test_validate_bounds_the_link_with_the_shows_own_gap() -> None:
    # One frame a tick fits the Mini's link with its own gap (1.2 ms), not with 50 ms of
    # silence after each frame at 50 Hz: validate must say so as the compile does.
    move = [MotionCue(0.0, origin("m"), {"body_z": 110.0, "roll": 5.0}, 2.0)]
    assert compile_diagnostics(_show({"rex": ("mini", move)})) == ()
    _, diags = _both(_show({"rex": ("mini", move)}, gap=0.05))
    assert [d.path for d in diags] == ["tracks.rex"]


def test_validate_finds_a_burst_of_settings_more_than_a_period_late() -> None:
    # Two settings far apart in the Mini's table are two frames: the second starts 1.98 ms
    # after the first, later than a period at 600 Hz (1.67 ms) but within two. validate must
    # bound the lateness by one period, as the compile refuses it.
    show = _show({"rex": ("mini", [SetCue(0.0, origin("set"), {"show_mode": "normal",
                                                                 "gait": "trot"})])},
                 control_rate=600.0)
    text, _ = _both(show)
    assert text.splitlines()[1] == (
        "show.yaml:1:5: error: tracks.rex: the link does not fit cue 'set': its frame planned "
        "at 0.000 s could only start at 0.002 s, more than one control period (1.667 ms) late "
        "at 115200 baud with 1.2 ms between frames; write fewer registers at once or lower "
        "control_rate, or set decimate: true")


def test_validate_warns_of_samples_decimated_half_a_period_late() -> None:
    # Three registers far apart are three frames a tick at 150 Hz: the last starts about 4 ms
    # late, within a period (6.67 ms) but past half of one, where decimate drops a sample.
    # validate bounds a decimating show by half a period, so it warns as the compile does.
    show = _show({"rex": ("mini", [MotionCue(0.0, origin("m"), {"vx": 3.0, "leg1_x": 3.0,
                                                                "servo_11": -4.0}, 1.0)])},
                 control_rate=150.0, decimate=True)
    warnings = compile_show(show).warnings
    assert compile_diagnostics(show) == warnings
    assert [d.format() for d in warnings] == [
        "show.yaml:1:5: warning: tracks.rex: decimated 1 of 36 trajectory sample frames to fit "
        "the link (first at 0.000 s); their values went out with later frames"]
