"""The fades of one ``led:`` cue sampled as one source make the frames of the fades one by one.

An ``led:`` cue with ``fade:`` resolves to one FadeCue per LED (same start, origin, length,
consecutive in the track). The planner samples such a group as one source when it can
(:meth:`XgoPlanner._fade_group`): a tick's sample is every LED's colour. On random Rider tracks
(groups in any LED order, with moves, settings that cut them, other fades and actions), the
frames must be those of sampling each fade alone, at the same times, under the same cues, on
the fast road and the general one (decimation's).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import examples, origin
from xgo_show.choreo.resolved import (
    ActionCue,
    Cue,
    FadeCue,
    MotionCue,
    ResolvedShow,
    ResolvedTrack,
    SetCue,
)
from xgo_show.compiler import compile_show
from xgo_show.compiler.planner import XgoPlanner, plan_xgo_track
from xgo_show.compiler.state import layout_of
from xgo_show.errors import CompileError
from xgo_show.profiles import get_profile

LEDS = ("led1", "led2", "led3", "led4")
STARTS = st.integers(0, 300).map(lambda ms: ms / 100)  # on and off the 20 ms tick grid
# Wide and narrow: a narrow fade's colour holds for a tick or two while a wide one's changes.
COLOURS = st.one_of(st.tuples(*[st.integers(0, 255)] * 3), st.tuples(*[st.integers(0, 30)] * 3))


@st.composite
def rider_tracks(draw: st.DrawFn) -> ResolvedTrack:
    cues: list[Cue] = []
    for n in range(draw(st.integers(1, 7))):
        o = origin(f"c{n}", n + 1)
        start = draw(STARTS)
        kind = draw(st.sampled_from(["led", "led", "led", "fade", "move", "set", "action"]))
        if kind == "led":  # an led: cue with fade: one FadeCue per LED, in the order written
            leds = draw(st.lists(st.sampled_from(LEDS), min_size=1, max_size=4, unique=True))
            length = draw(st.sampled_from([0.1, 0.5, 1.0, 2.0, 7.0]))
            cues.extend(FadeCue(start, o, led, draw(COLOURS), length) for led in leds)
        elif kind == "fade":
            cues.append(FadeCue(start, o, draw(st.sampled_from(LEDS)), draw(COLOURS),
                                draw(st.floats(0.1, 2.0))))
        elif kind == "move":
            cues.append(MotionCue(start, o, {"roll": draw(st.sampled_from([-5.0, 5.0]))},
                                  draw(st.sampled_from([None, 1.0])), interrupts=True))
        elif kind == "set":
            cues.append(SetCue(start, o, {draw(st.sampled_from(LEDS)): draw(COLOURS)},
                               interrupts=True))
        else:
            cues.append(ActionCue(start, o, 255, "reset", 1.0, interrupts=True))
    cues.sort(key=lambda c: c.start)  # stable: a group's fades stay together
    return ResolvedTrack("p", "rider", tuple(cues))


@contextmanager
def fades_one_by_one() -> Iterator[None]:
    """Every fade sampled alone (the reference)."""
    grouped = XgoPlanner._fade_group
    XgoPlanner._fade_group = lambda self, i: [self.fades[i]]  # type: ignore[method-assign]
    try:
        yield
    finally:
        XgoPlanner._fade_group = grouped  # type: ignore[method-assign]


def _frames(track: ResolvedTrack, details: bool) -> tuple[object, ...]:
    profile = get_profile("rider")
    plan = plan_xgo_track(layout_of(profile), track, rate=50.0, link=profile.link,
                          gap=profile.link.gap, details=details)
    # ``order`` aside: a frame of a group files under its first fade's cue order, and the
    # fades of a group are consecutive cues of one origin, so nothing else can tell. Which
    # fields a frame holds is kept with details alone (as in test_supersede): without them a
    # tick where a fade hands over to a later one on fewer LEDs is a tick of samples when
    # each fade is its own source and of writes when they are grouped, the same frame bytes
    # either way (test_a_hand_over_to_fewer_leds_compiles_the_same).
    return (tuple((f.t_us, f.data, f.origin, f.droppable, f.action, f.duration,
                   *((f.fields,) if details else ())) for f in plan.frames),
            plan.samples, plan.end,
            tuple(d.format() for d in plan.diagnostics))


@settings(max_examples=examples(300), deadline=None)
@given(rider_tracks(), st.booleans())
def test_a_group_of_fades_makes_the_frames_of_its_fades(track: ResolvedTrack,
                                                        details: bool) -> None:
    with fades_one_by_one():
        alone = _frames(track, details)
    assert _frames(track, details) == alone


@settings(max_examples=examples(100), deadline=None)
@given(rider_tracks(), st.booleans())
def test_a_group_of_fades_compiles_to_the_same_schedule(track: ResolvedTrack,
                                                        decimate: bool) -> None:
    show = ResolvedShow("s", "show.yaml", (track,), control_rate=50.0, decimate=decimate)

    def compiled() -> object:
        try:
            return compile_show(show)
        except CompileError as exc:
            return str(exc)

    with fades_one_by_one():
        alone = compiled()
    assert compiled() == alone


def test_a_hand_over_to_fewer_leds_compiles_the_same() -> None:
    # Found by the property above (train 3 of session 9): a group of four fades ends on the
    # tick where a later fade of one of its LEDs starts. Alone, the later fade's first sample
    # replaces its LED's last one and the tick stays samples; grouped, the group's sample
    # covers LEDs the later one does not, so the tick is writes. Same bytes, same schedule.
    def fade(start: float, line: int, cue: str, led: str, to: tuple[int, int, int]) -> FadeCue:
        return FadeCue(start, origin(cue, line), led, to, 1.0)

    track = ResolvedTrack("p", "rider", (
        fade(0.0, 1, "c0", "led4", (0, 0, 82)),
        fade(0.3, 2, "c1", "led1", (0, 0, 0)),
        fade(0.3, 2, "c1", "led2", (0, 0, 25)),
        fade(0.3, 2, "c1", "led4", (0, 0, 0)),
        fade(0.3, 2, "c1", "led3", (0, 0, 0)),
        fade(1.3, 3, "c2", "led2", (0, 0, 0)),
    ))
    for details in (False, True):
        with fades_one_by_one():
            alone = _frames(track, details)
        assert _frames(track, details) == alone
    for decimate in (False, True):
        show = ResolvedShow("s", "show.yaml", (track,), control_rate=50.0, decimate=decimate)
        with fades_one_by_one():
            schedule = compile_show(show)
        assert compile_show(show) == schedule


def test_an_led_cue_on_two_leds_is_one_source() -> None:
    # The benchmark's Rider: led1 and led2 fade together beside a move.
    o = origin("glow", 3)
    track = ResolvedTrack("p", "rider", (
        MotionCue(0.0, origin("lean", 2), {"roll": 5.0}, 1.0),
        FadeCue(0.0, o, "led1", (250, 10, 0), 1.0),
        FadeCue(0.0, o, "led2", (0, 10, 250), 1.0),
    ))
    planner = XgoPlanner(layout_of(get_profile("rider")), track, 50.0)
    planner.plan()
    assert [len(planner._fade_group(i)) for i in range(len(planner.fades))] == [2, 1]
    sources = {src for entry in planner.ticks.values() if isinstance(entry, list)
               for src, _ in entry}
    assert any(len(src.addresses) == 2 for src in sources)


def test_no_group_across_an_action_or_out_of_address_order() -> None:
    o = origin("glow", 3)
    fades = (FadeCue(0.0, o, "led2", (250, 10, 0), 1.0), FadeCue(0.0, o, "led1", (0, 90, 90), 1.0))
    layout = layout_of(get_profile("rider"))
    backwards = XgoPlanner(layout, ResolvedTrack("p", "rider", fades), 50.0)
    backwards.plan()
    assert len(backwards._fade_group(0)) == 1
    forwards = fades[::-1]
    action = ActionCue(0.5, origin("reset", 4), 255, "reset", 1.0)
    with_action = XgoPlanner(layout, ResolvedTrack("p", "rider", (*forwards, action)), 50.0)
    with_action.plan()
    assert len(with_action._fade_group(0)) == 1
    plain = XgoPlanner(layout, ResolvedTrack("p", "rider", forwards), 50.0)
    plain.plan()
    assert len(plain._fade_group(0)) == 2


def test_an_action_during_led_fades_keeps_their_frames() -> None:
    # After a preset action nothing counts as sent: led2 changes about every other tick and
    # holds at the tick after the action (0.56 s), where only led1 changes; it must not go out
    # there (it would, sampled with led1 as one source: compared with what was sent).
    o = origin("glow", 3)
    track = ResolvedTrack("p", "rider", (
        FadeCue(0.0, o, "led1", (255, 255, 255), 1.0),
        FadeCue(0.0, o, "led2", (25, 0, 0), 1.0),
        ActionCue(0.54, origin("reset", 4), 255, "reset", 0.1),
    ))
    for details in (False, True):
        with fades_one_by_one():
            alone = _frames(track, details)
        assert _frames(track, details) == alone


def test_validate_walks_a_group_of_fades_without_sampling_it() -> None:
    from xgo_show.compiler.linkfit import _CueWalk

    o = origin("glow", 3)
    track = ResolvedTrack("p", "rider", (
        FadeCue(0.0, o, "led1", (250, 10, 0), 1.0), FadeCue(0.0, o, "led2", (0, 10, 250), 1.0)))
    walk = _CueWalk(layout_of(get_profile("rider")), track, 50.0)
    walk.plan()
    assert len(walk._fade_group(0)) == 2 and not walk.ticks


def test_a_group_is_kept_unless_an_action_goes_out_from_its_start_to_its_stop() -> None:
    # The fades run from 1.0 s to 2.0 s: an action at either end, or between, splits the group;
    # actions before or after it (in any cue order) do not.
    o = origin("glow", 3)
    fades = (FadeCue(1.0, o, "led1", (0, 90, 90), 1.0), FadeCue(1.0, o, "led2", (250, 10, 0), 1.0))
    layout = layout_of(get_profile("rider"))
    for times, grouped in (((), True), ((0.5,), True), ((2.5,), True), ((2.5, 0.5), True),
                           ((1.0,), False), ((2.0,), False), ((1.5,), False),
                           ((2.5, 1.99, 0.5), False), ((0.98,), True), ((2.02,), True)):
        actions = tuple(ActionCue(t, origin(f"reset{n}", 5 + n), 255, "reset", 0.01)
                        for n, t in enumerate(times))
        planner = XgoPlanner(layout, ResolvedTrack("p", "rider", (*fades, *actions)), 50.0)
        planner.plan()
        assert (len(planner._fade_group(0)) == 2) is grouped, times
