"""The compiler's fast road for sample ticks gives the very frames of the general one.

``plan_xgo_track(details=True)`` turns every tick into Writes and merges them the general way
(the reference); ``details=False`` builds the frames of ticks that only moves and fades write
straight from their samples. On random tracks (moves that overlap, cut and chain, fades,
settings over moved registers, actions, the reset) both must give the same frames, byte for
byte, at the same times, filed under the same cues.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from xgo_show.choreo.resolved import ActionCue, Cue, FadeCue, MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler.frames import PlannedFrame, TrackPlan
from xgo_show.compiler.planner import plan_xgo_track
from xgo_show.compiler.state import layout_of
from xgo_show.profiles import get_profile

MOVABLE = {
    "mini": ("vx", "body_x", "body_y", "body_z", "roll", "pitch", "yaw", "leg1_x", "leg1_z"),
    "rider": ("vx", "body_z", "roll"),
}
SETTABLE = {
    "mini": {"body_z": [80.0, 110.0], "roll": [-5.0, 5.0], "vx": [0.0, 10.0],
             "gait": ["walk", "trot"], "pace": ["fast", "slow"]},
    "rider": {"roll": [-5.0, 5.0], "vx": [0.0, 0.5], "led1": [(1, 2, 3), (200, 0, 40)]},
}
ACTIONS = {"mini": [(13, "wave", 7.0), (255, "reset", 1.0)], "rider": [(255, "reset", 1.0)]}
# Starts on a millisecond grid and on 132 bpm beats: on and off the 20 ms tick grid.
STARTS = st.one_of(st.integers(0, 8000).map(lambda ms: ms / 1000),
                   st.integers(0, 16).map(lambda beat: beat * 60 / 132))


@st.composite
def tracks(draw: st.DrawFn) -> ResolvedTrack:
    model = draw(st.sampled_from(["mini", "rider"]))
    profile = get_profile(model)
    cues: list[Cue] = []
    for n in range(draw(st.integers(1, 8))):
        o = origin(f"c{n}", n + 1)
        start = draw(STARTS)
        kinds = ["move", "move", "move", "set", "action"] + ["fade"] * (model == "rider") * 2
        kind = draw(st.sampled_from(kinds))
        if kind == "move":
            names = draw(st.lists(st.sampled_from(MOVABLE[model]), min_size=1, max_size=4,
                                  unique=True))
            targets = {}
            for name in names:
                reg = profile.register(name)
                assert reg.minimum is not None and reg.maximum is not None
                fraction = draw(st.floats(0.2, 0.8))
                targets[name] = round(reg.minimum + (reg.maximum - reg.minimum) * fraction, 1)
            duration = draw(st.one_of(st.none(), st.floats(1.0, 3.0)))
            cues.append(MotionCue(start, o, targets, duration, interrupts=True))
        elif kind == "set":
            name = draw(st.sampled_from(sorted(SETTABLE[model])))
            cues.append(SetCue(start, o, {name: draw(st.sampled_from(SETTABLE[model][name]))},
                               interrupts=True))
        elif kind == "fade":
            led = draw(st.sampled_from(["led1", "led2", "led3"]))
            colour = draw(st.tuples(*[st.integers(0, 255)] * 3))
            cues.append(FadeCue(start, o, led, colour, draw(st.floats(0.1, 2.0))))
        else:
            action_id, name, length = draw(st.sampled_from(ACTIONS[model]))
            cues.append(ActionCue(start, o, action_id, name, length, interrupts=True))
    cues.sort(key=lambda c: c.start)
    return ResolvedTrack("p", model, tuple(cues))


def _plan(track: ResolvedTrack, *, details: bool) -> TrackPlan:
    profile = get_profile(track.model)
    return plan_xgo_track(layout_of(profile), track, rate=50.0, link=profile.link,
                          gap=profile.link.gap, details=details)


def _essence(f: PlannedFrame) -> tuple[object, ...]:
    return (f.t_us, f.data, f.origin, f.order, f.droppable, f.action, f.duration)


@settings(max_examples=150, deadline=None)
@given(tracks())
def test_sample_ticks_give_the_same_frames_as_writes(track: ResolvedTrack) -> None:
    reference = _plan(track, details=True)
    fast = _plan(track, details=False)
    assert [_essence(f) for f in fast.frames] == [_essence(f) for f in reference.frames]
    assert fast.samples == reference.samples
    assert fast.end == reference.end
    assert fast.diagnostics == reference.diagnostics


def test_crowded_ticks_give_the_same_frames_as_writes(o) -> None:  # type: ignore[no-untyped-def]
    # Cases the random tracks may miss: a third source on a register two others already share
    # a tick on, a setting and an action landing on sample ticks, a move cut by another.
    crowded = [
        ResolvedTrack("p", "rider", (
            FadeCue(0.0, o("f1"), "led1", (255, 0, 0), 2.0),
            MotionCue(0.0, o("m"), {"roll": 8.0}, 2.0),
            FadeCue(0.0, o("f2"), "led2", (0, 255, 0), 2.0),
            FadeCue(1.0, o("f3"), "led1", (0, 0, 255), 2.0),
            SetCue(1.5, o("s"), {"led2": (1, 2, 3)}),
        )),
        ResolvedTrack("p", "mini", (
            MotionCue(0.0, o("a"), {"body_z": 110.0, "roll": 5.0, "yaw": 9.0}, 3.0),
            MotionCue(1.0, o("b"), {"roll": -5.0}, 1.0, interrupts=True),
            SetCue(1.2, o("s"), {"pitch": 4.0, "gait": "trot"}),
            ActionCue(2.5, o("w"), 13, "wave", 7.0, interrupts=True),
            MotionCue(10.0, o("c"), {"body_z": 90.0}, 1.0),
        )),
    ]
    for track in crowded:
        reference = _plan(track, details=True)
        fast = _plan(track, details=False)
        assert [_essence(f) for f in fast.frames] == [_essence(f) for f in reference.frames]


def test_details_keep_fields_and_writes_for_decimation(o) -> None:  # type: ignore[no-untyped-def]
    track = ResolvedTrack("p", "mini", (
        MotionCue(0.0, o("m"), {"body_z": 110.0, "yaw": 10.0}, 1.0),
    ))
    detailed = _plan(track, details=True).frames
    lean = _plan(track, details=False).frames
    assert all(f.fields and f.written for f in detailed)
    # The fast road leaves them out (empty, as their type says: whatever iterates them still
    # can): pacing reads them only to decimate.
    assert all(f.fields == () and f.written == () for f in lean)
    assert len(detailed) == len(lean) > 10



def _timeline(model: str, plan: TrackPlan) -> dict[str, list[tuple[int, bytes]]]:
    """Per register, each planned change of its bytes from the initial ones: (us, new bytes)."""
    layout = layout_of(get_profile(model))
    held = {r.name: r.initial for r in layout.profile.registers if r.initial is not None}
    changes: dict[str, list[tuple[int, bytes]]] = {}
    for f in plan.frames:
        address, payload = f.data[4], f.data[5:-3]
        regs = layout.walk(address, len(payload))
        assert regs is not None
        at = 0
        for reg in regs:
            raw = payload[at:at + reg.size]
            at += reg.size
            if held.get(reg.name) != raw:
                held[reg.name] = raw
                changes.setdefault(reg.name, []).append((f.t_us, raw))
    return changes


def test_cues_on_other_registers_at_the_same_ticks_change_nothing(o) -> None:  # type: ignore[no-untyped-def]
    # Moves and fades on different registers share ticks (and frames); each register still
    # changes exactly when it changes with its cue alone.
    beat = 60 / 132
    shows = {
        "mini": [
            MotionCue(0.0, o("a"), {"body_z": 110.0, "pitch": 8.0}, 2.0),
            MotionCue(0.5, o("b"), {"yaw": -10.0}, 2.0),
            MotionCue(beat, o("c"), {"leg1_x": 10.0, "leg1_z": 80.0}, 3 * beat),
            MotionCue(1.0, o("d"), {"roll": 6.0}),
        ],
        "rider": [
            FadeCue(0.0, o("f1"), "led1", (255, 0, 40), 2.0),
            FadeCue(0.1, o("f2"), "led2", (0, 90, 255), 2 * beat),
            MotionCue(0.3, o("m"), {"body_z": 0.05, "roll": -8.0}, 1.5),
            FadeCue(beat, o("f3"), "led3", (9, 9, 9), 1.0),
        ],
    }
    for model, cues in shows.items():
        together = _timeline(model, _plan(ResolvedTrack("p", model, tuple(cues)),
                                          details=False))
        alone: dict[str, list[tuple[int, bytes]]] = {}
        for cue in cues:
            alone.update(_timeline(model, _plan(ResolvedTrack("p", model, (cue,)),
                                                details=False)))
        assert together == alone


@st.composite
def chained_tracks(draw: st.DrawFn) -> ResolvedTrack:
    """Moves one after another on the same registers (a Rider's with LED fades beside them),
    as long shows are: long stretches of ticks the same sources write, cue after cue, which
    the fast road makes into frames list by list (fastpath.TickFrames.stretch and
    samples_stretch)."""
    model = draw(st.sampled_from(["mini", "rider"]))
    profile = get_profile(model)
    names = draw(st.lists(st.sampled_from(MOVABLE[model][1:]), min_size=1, max_size=4,
                          unique=True))
    leds = draw(st.lists(st.sampled_from(["led1", "led2", "led3"]), max_size=2, unique=True)
                ) if model == "rider" else []
    cues: list[Cue] = []
    t = draw(st.integers(0, 30)) / 50
    for n in range(draw(st.integers(2, 5))):
        o = origin(f"c{n}", n + 1)
        duration = draw(st.integers(50, 120)) / 50 + draw(st.sampled_from([0.0, 0.007]))
        targets = {}
        for name in names:
            reg = profile.register(name)
            assert reg.minimum is not None and reg.maximum is not None
            fraction = draw(st.floats(0.2, 0.8))
            targets[name] = round(reg.minimum + (reg.maximum - reg.minimum) * fraction, 1)
        cues.append(MotionCue(t, o, targets, duration))
        for led in leds:  # one led: cue, as the resolver makes it: a fade per LED
            colour = draw(st.tuples(*[st.integers(0, 255)] * 3))
            cues.append(FadeCue(t, o, led, colour, duration))
        t += duration + draw(st.sampled_from([0.0, 0.0, 0.02, 0.5]))
    return ResolvedTrack("p", model, tuple(cues))


@settings(max_examples=60, deadline=None)
@given(chained_tracks())
def test_stretches_of_the_same_sources_give_the_same_frames_as_writes(
    track: ResolvedTrack,
) -> None:
    reference = _plan(track, details=True)
    fast = _plan(track, details=False)
    assert [_essence(f) for f in fast.frames] == [_essence(f) for f in reference.frames]
    assert fast.samples == reference.samples


def test_settings_on_other_registers_in_the_middle_of_a_move_change_nothing(o) -> None:  # type: ignore[no-untyped-def]
    # A setting filed at a tick a move samples later (on the grid, mid-move, one or a few):
    # the move's sample there is its own, not another tick's.
    for starts in ((1.0,), (0.5, 1.2, 1.6), tuple(0.2 * n for n in range(1, 10))):
        cues = [MotionCue(0.0, o("m"), {"body_z": 110.0, "yaw": 9.0}, 2.0),
                *(SetCue(t, o(f"s{n}"), {"vx": [0.0, 10.0][n % 2]}) for n, t in enumerate(starts))]
        together = _timeline("mini", _plan(ResolvedTrack("p", "mini", tuple(cues)),
                                           details=False))
        alone = _timeline("mini", _plan(ResolvedTrack("p", "mini", (cues[0],)), details=False))
        assert {k: v for k, v in together.items() if k != "vx"} == alone
