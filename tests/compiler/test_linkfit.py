"""validate's short cut (compiler/linkfit.py) finds what the full compile finds, always.

``compile_diagnostics`` skips sampling and pacing for an XGO performer whose frames provably fit
its link. On random shows (moves over many registers that overlap, cut and chain, fades, long
settings, actions, rates and gaps from easy to far too tight, with and without decimate):

* each step of the proof against the full compile's frames: every register a frame writes is
  in the model at that instant; an instant's frames take no more link time than the model
  allows, and none less than its smallest frame; the closed-form sweep is at least (and
  nearly) the pacing recurrence run instant by instant on the model;
* end to end: the bound is never below the real lateness, and compile_diagnostics returns (or
  raises) exactly what compile_show does.
"""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from xgo_show.choreo.resolved import (
    ActionCue,
    Cue,
    FadeCue,
    MotionCue,
    ResolvedShow,
    ResolvedTrack,
    SetCue,
)
from xgo_show.compiler import compile_diagnostics, compile_show
from xgo_show.compiler.frames import tick_us, to_us
from xgo_show.compiler.linkfit import (
    LinkModel,
    _CueWalk,
    late_bound_us,
    link_model,
    quick_track_diagnostics,
)
from xgo_show.compiler.pacing import pace, wire_us
from xgo_show.compiler.planner import plan_xgo_track
from xgo_show.compiler.state import layout_of
from xgo_show.errors import XgoShowError
from xgo_show.families import get_family
from xgo_show.profiles import Link, get_profile

MOVABLE = {
    "mini": ("vx", "body_x", "body_y", "body_z", "roll", "pitch", "yaw", "leg1_x", "leg1_y",
             "leg1_z", "leg2_x", "leg2_z", "leg3_y", "servo_11", "servo_13"),
    "rider": ("vx", "body_z", "roll"),
}
SETTABLE = {
    "mini": {"body_z": [80.0, 110.0], "roll": [-5.0, 5.0], "vx": [0.0, 10.0],
             "gait": ["walk", "trot"], "pace": ["fast", "slow"], "bt_name": ["a" * 20, "b"]},
    "rider": {"roll": [-5.0, 5.0], "vx": [0.0, 0.5], "led1": [(1, 2, 3), (200, 0, 40)],
              "bt_name": ["rider-" * 3]},
}
ACTIONS = {"mini": [(13, "wave", 7.0), (255, "reset", 1.0)], "rider": [(255, "reset", 1.0)]}
RATES = [10.0, 30.0, 50.0, 100.0, 144.0, 200.0, 1000.0]


@st.composite
def tracks(draw: st.DrawFn, name: str = "p") -> ResolvedTrack:
    model = draw(st.sampled_from(["mini", "rider"]))
    profile = get_profile(model)
    cues: list[Cue] = []
    # Starts on a millisecond grid, on 132 bpm beats, and right at other cues' ends.
    starts = st.one_of(st.integers(0, 6000).map(lambda ms: ms / 1000),
                       st.integers(0, 12).map(lambda beat: beat * 60 / 132),
                       st.integers(0, 6).map(float))
    for n in range(draw(st.integers(1, 10))):
        o = origin(f"c{n}", n + 1)
        start = draw(starts)
        kinds = ["move"] * 4 + ["set", "action"] + ["fade"] * (model == "rider") * 3
        kind = draw(st.sampled_from(kinds))
        if kind == "move":
            names = draw(st.lists(st.sampled_from(MOVABLE[model]), min_size=1, max_size=8,
                                  unique=True))
            targets = {}
            for reg_name in names:
                reg = profile.register(reg_name)
                assert reg.minimum is not None and reg.maximum is not None
                fraction = draw(st.floats(0.05, 0.95))
                targets[reg_name] = round(reg.minimum + (reg.maximum - reg.minimum) * fraction,
                                          1)
            duration = draw(st.one_of(st.none(), st.floats(0.05, 3.0)))
            cues.append(MotionCue(start, o, targets, duration, interrupts=True))
        elif kind == "set":
            reg_name = draw(st.sampled_from(sorted(SETTABLE[model])))
            value = draw(st.sampled_from(SETTABLE[model][reg_name]))
            cues.append(SetCue(start, o, {reg_name: value}, interrupts=True))
        elif kind == "fade":
            led = draw(st.sampled_from(["led1", "led2", "led3", "led4"]))
            colour = draw(st.tuples(*[st.integers(0, 255)] * 3))
            cues.append(FadeCue(start, o, led, colour, draw(st.floats(0.0, 3.0))))
        else:
            action_id, action, length = draw(st.sampled_from(ACTIONS[model]))
            cues.append(ActionCue(start, o, action_id, action, length, interrupts=True))
    cues.sort(key=lambda c: c.start)
    return ResolvedTrack(name, model, tuple(cues))


@st.composite
def shows(draw: st.DrawFn) -> ResolvedShow:
    performers = draw(st.integers(1, 3))
    resolved = tuple(draw(tracks(f"p{i}")) for i in range(performers))
    gap = draw(st.sampled_from([None, 0.001, 0.003, 0.012]))
    return ResolvedShow("random", "show.yaml", resolved, control_rate=draw(st.sampled_from(RATES)),
                        gap=gap, decimate=draw(st.booleans()))


def _outcome(compile_fn: object, show: ResolvedShow) -> object:
    """What a compile gives: its warnings, or its error's type, message and diagnostics."""
    assert callable(compile_fn)
    try:
        found = compile_fn(show)
    except XgoShowError as exc:
        return (type(exc).__name__, str(exc), getattr(exc, "diagnostics", None))
    return tuple(found if isinstance(found, tuple) else found.warnings)


def _real_lateness(track: ResolvedTrack, rate: float, gap: float) -> int:
    """The latest any frame of ``track`` starts after its planned time, fully compiled."""
    profile = get_profile(track.model)
    link = Link(profile.link.baud, gap, profile.link.bits_per_byte)
    plan, _ = get_family(profile).plan_track(profile, track, rate=rate, link=link, gap=gap,
                                             details=False)
    paced = pace(plan.frames, link=link, gap_us=to_us(gap), period_us=to_us(1 / rate))
    return max((p.start_us - p.frame.t_us for p in paced.frames), default=0)


def _instants(model: LinkModel, rate: float) -> dict[int, set[int]]:
    """The model spelt out: µs -> every register it lets the performer write then."""
    out: dict[int, set[int]] = {}
    counts: dict[int, int] = {}
    ks = sorted(model.spans)
    for a, b in itertools.pairwise(ks):
        for address, delta in model.spans[a]:
            counts[address] = counts.get(address, 0) + delta
            assert counts[address] >= 0
        live = {address for address, n in counts.items() if n}
        for k in range(a, b):
            if live:
                out[tick_us(k, rate)] = set(live)
    for t_us, written in model.points.items():
        out.setdefault(t_us, set()).update(written)
    return out


def _recurrence(model: LinkModel, rate: float) -> float:
    """The pacing recurrence on the model's costs, instant by instant (the sweep's reference)."""
    free, worst = -math.inf, 0.0
    for t_us, written in sorted(_instants(model, rate).items()):
        c = sum(model.cost[a] for a in written)
        late = max(0.0, free - t_us)
        worst = max(worst, late + c - model.smallest)
        free = t_us + late + c
    return worst


def _walked(track: ResolvedTrack, rate: float) -> _CueWalk:
    walk = _CueWalk(layout_of(get_profile(track.model)), track, rate)
    walk.plan()
    return walk


GAPS = [0.001, 0.0012, 0.005]


@settings(max_examples=100, deadline=None)
@given(tracks(), st.sampled_from(RATES), st.sampled_from(GAPS))
def test_the_model_holds_every_frame_and_its_link_time(track: ResolvedTrack, rate: float,
                                                       gap: float) -> None:
    profile = get_profile(track.model)
    link = Link(profile.link.baud, gap, profile.link.bits_per_byte)
    model = link_model(_walked(track, rate), rate=rate, link=link, gap_us=to_us(gap))
    try:
        plan = plan_xgo_track(layout_of(profile), track, rate=rate, link=link, gap=gap,
                              details=True)
    except XgoShowError:  # sampling refused a value: the model must have left it to the compile
        assert model is None
        return
    if model is None:
        event("not modelled")
        return
    allowed = _instants(model, rate)
    spent: dict[int, int] = {}
    written: dict[int, set[int]] = {}
    for f in plan.frames:
        addresses = {w.address for w in f.written}
        assert addresses, "a frame without a write of its tick"
        assert addresses <= allowed.get(f.t_us, set()), f"frame at {f.t_us} us"
        took = wire_us(link, len(f.data)) + to_us(gap)
        assert took >= model.smallest
        spent[f.t_us] = spent.get(f.t_us, 0) + took
        written.setdefault(f.t_us, set()).update(addresses)
    for t_us, took in spent.items():
        assert took <= sum(model.cost[a] for a in written[t_us])


@settings(max_examples=100, deadline=None)
@given(tracks(), st.sampled_from(RATES), st.sampled_from(GAPS))
def test_the_sweep_is_the_recurrence_in_closed_form(track: ResolvedTrack, rate: float,
                                                    gap: float) -> None:
    profile = get_profile(track.model)
    link = Link(profile.link.baud, gap, profile.link.bits_per_byte)
    walk = _walked(track, rate)
    model = link_model(walk, rate=rate, link=link, gap_us=to_us(gap))
    if model is None:
        return
    bound = late_bound_us(walk, rate=rate, link=link, gap_us=to_us(gap), limit=math.inf)
    exact = _recurrence(model, rate)
    assert bound is not None and bound >= exact - 1e-6
    # Nearly: the sweep takes the shortest tick spacing minus 1 us for every spacing.
    assert bound <= exact + 2 * len(_instants(model, rate)) + 1


@settings(max_examples=100, deadline=None)
@given(tracks(), st.sampled_from(RATES), st.sampled_from(GAPS))
def test_the_bound_is_never_below_the_real_lateness(track: ResolvedTrack, rate: float,
                                                    gap: float) -> None:
    profile = get_profile(track.model)
    link = Link(profile.link.baud, gap, profile.link.bits_per_byte)
    walk = _CueWalk(layout_of(profile), track, rate)
    walk.plan()
    bound = late_bound_us(walk, rate=rate, link=link, gap_us=to_us(gap), limit=math.inf)
    try:
        real = _real_lateness(track, rate, gap)
    except XgoShowError:  # sampling refused a value: the bound must have left it to the compile
        assert bound is None
        return
    if bound is None:
        event("not bounded")
        return
    event("bound within 2x" if bound <= 2 * real + 5000 else "bound loose")
    assert bound >= real


@settings(max_examples=150, deadline=None)
@given(shows())
def test_validate_finds_exactly_what_the_compile_finds(show: ResolvedShow) -> None:
    for track in show.tracks:
        profile = get_profile(track.model)
        gap = profile.link.gap if show.gap is None else show.gap
        quick = quick_track_diagnostics(
            track, profile, rate=show.control_rate,
            link=Link(profile.link.baud, gap, profile.link.bits_per_byte), gap_us=to_us(gap),
            period_us=to_us(1 / show.control_rate), decimate=show.decimate)
        event("short cut" if quick is not None else "full compile")
    assert _outcome(compile_diagnostics, show) == _outcome(compile_show, show)


def test_a_busy_show_that_fits_takes_the_short_cut(o) -> None:  # type: ignore[no-untyped-def]
    # Ten minutes of back-to-back moves of four registers at 50 Hz (benchmarks/compile_speed):
    # each tick needs about 8 ms of a 20 ms period; one move's end and the next's start meet.
    cues = tuple(MotionCue(2.0 * n, o(f"m{n}"), {"body_z": 90.0 + n % 2 * 20, "roll": 3.0 - n % 3,
                                                  "pitch": -4.0 + n % 5, "yaw": 5.0}, 2.0)
                 for n in range(300))
    track = ResolvedTrack("p", "mini", cues)
    profile = get_profile("mini")
    found = quick_track_diagnostics(track, profile, rate=50.0, link=profile.link,
                                    gap_us=1200, period_us=20_000, decimate=True)
    assert found == []


@pytest.mark.parametrize("rate", [200.0, 1000.0])
def test_a_show_too_dense_to_bound_is_compiled_in_full(o, rate: float) -> None:  # type: ignore[no-untyped-def]
    # Twelve registers at each tick: more link time than a tick at these rates, as a bound;
    # the full compile decides (and finds the link does not fit at 1000 Hz).
    regs = MOVABLE["mini"][:12]
    profile = get_profile("mini")
    targets = {}
    for name in regs:
        reg = profile.register(name)
        assert reg.minimum is not None and reg.maximum is not None
        targets[name] = reg.minimum + (reg.maximum - reg.minimum) * 0.7
    track = ResolvedTrack("p", "mini", (MotionCue(0.0, o("m"), targets, 3.0),))
    assert quick_track_diagnostics(track, profile, rate=rate, link=profile.link, gap_us=1200,
                                   period_us=to_us(1 / rate), decimate=False) is None
    show = ResolvedShow("dense", "show.yaml", (track,), control_rate=rate)
    assert _outcome(compile_diagnostics, show) == _outcome(compile_show, show)
