"""The fast road's frames on small hand-made shows, to the byte: LED fades (a straight line
from one colour to another, so every tick's colour is known by hand) alone, side by side,
joining and leaving one another's ticks, split by a setting, and filling the register between
them. Both roads must give exactly these frames (test_fast_path checks them against each other
on random tracks; here both against what the robot must be sent)."""

from __future__ import annotations

import pytest

from tests.compiler.conftest import origin as o
from xgo_show.choreo.resolved import Cue, FadeCue, ResolvedTrack, SetCue
from xgo_show.compiler.frames import TrackPlan
from xgo_show.compiler.planner import plan_xgo_track
from xgo_show.compiler.state import layout_of
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile
from xgo_show.wire.xgo import TYPE_WRITE_RIDER, write_frame

RIDER = get_profile("rider")
assert RIDER.write_type == TYPE_WRITE_RIDER
LED1, LED2, LED3 = (RIDER.register(f"led{n}").address for n in (1, 2, 3))
A, B, C, S = o("a", 1), o("b", 2), o("c", 3), o("s", 4)

Frame = tuple[int, bytes, Origin | None, bool]  # time (us), bytes, cue, only samples


def _plan(cues: list[Cue], *, details: bool) -> TrackPlan:
    track = ResolvedTrack("p", "rider", tuple(cues))
    return plan_xgo_track(layout_of(RIDER), track, rate=50.0, link=RIDER.link,
                          gap=RIDER.link.gap, details=details)


def _frames(cues: list[Cue], details: bool) -> list[Frame]:
    plan = _plan(cues, details=details)
    frames = [(f.t_us, f.data, f.origin, f.droppable) for f in plan.frames]
    assert plan.samples == sum(f[3] for f in frames)
    return frames


def _sample(t_ms: int, address: int, *colours: tuple[int, int, int], cue: Origin = A
            ) -> Frame:
    """A frame at ``t_ms`` of LED colours from ``address`` on, holding only samples."""
    return (t_ms * 1000, _wire(address, bytes(c for rgb in colours for c in rgb)), cue, True)


def _wire(address: int, data: bytes) -> bytes:
    return write_frame(address, data, write_type=TYPE_WRITE_RIDER)


@pytest.mark.parametrize("details", [False, True])
def test_a_fade_alone_sends_its_colour_every_tick_then_its_end(details: bool) -> None:
    # 0 to (100, 50, 0) over 0.1 s at 50 Hz: a fifth of the way a tick.
    cues: list[Cue] = [FadeCue(0.0, A, "led1", (100, 50, 0), 0.1)]
    assert _frames(cues, details) == [
        _sample(20 * k, LED1, (20 * k, 10 * k, 0)) for k in range(6)]


@pytest.mark.parametrize("details", [False, True])
def test_fades_joining_and_leaving_each_others_ticks(details: bool) -> None:
    # a fades led1 over 0.2 s (40, 20, 0 a tick); b fades led2 from 60 ms to 120 ms, on a's
    # ticks (one frame for both LEDs, filed under a, the earlier cue); a setting of led3 at
    # 160 ms goes out with a's sample, led2 between them re-sent as b left it; then a alone.
    cues: list[Cue] = [
        FadeCue(0.0, A, "led1", (200, 100, 0), 0.2),
        FadeCue(0.06, B, "led2", (0, 0, 40), 0.06),
        SetCue(0.16, S, {"led3": (1, 2, 3)}),
    ]

    def a(k: int) -> tuple[int, int, int]:
        return (20 * k, 10 * k, 0)

    assert _frames(cues, details) == [
        _sample(0, LED1, a(0)),
        _sample(20, LED1, a(1)),
        _sample(40, LED1, a(2)),
        _sample(60, LED1, a(3), (0, 0, 0)),
        _sample(80, LED1, a(4), (0, 0, 13)),  # 40 / 3
        _sample(100, LED1, a(5), (0, 0, 27)),
        _sample(120, LED1, a(6), (0, 0, 40)),  # b's end: its exact colour
        _sample(140, LED1, a(7)),
        (160_000, _wire(LED1, bytes((*a(8), 0, 0, 40, 1, 2, 3))), A, False),
        _sample(180, LED1, a(9)),
        _sample(200, LED1, a(10)),
    ]


@pytest.mark.parametrize("details", [False, True])
def test_frames_of_two_fades_are_filed_under_the_earlier_cue(details: bool) -> None:
    # The later cue (c) on the lower address: each frame still goes under b.
    cues: list[Cue] = [
        FadeCue(0.0, B, "led2", (0, 60, 0), 0.06),
        FadeCue(0.0, C, "led1", (30, 0, 0), 0.06),
    ]
    assert _frames(cues, details) == [
        _sample(20 * k, LED1, (10 * k, 0, 0), (0, 20 * k, 0), cue=B) for k in range(4)]


@pytest.mark.parametrize("details", [False, True])
def test_a_register_between_two_fades_is_filled_with_what_it_holds_and_counts_as_sent(
    details: bool,
) -> None:
    # Fades of led1 and led3 share ticks: one frame a tick carries both, led2 between them
    # with its initial colour (black: never sent before). Then a fade of led2 from black (its
    # colour at the first tick): black went out as a filler, so it is not sent again.
    assert RIDER.register("led2").initial == bytes(3)
    cues: list[Cue] = [
        FadeCue(0.02, A, "led1", (40, 0, 0), 0.04),
        FadeCue(0.02, C, "led3", (0, 0, 80), 0.04),
        FadeCue(0.1, B, "led2", (0, 0, 40), 0.04),
    ]
    assert _frames(cues, details) == [
        *[_sample(20 + 20 * k, LED1, (20 * k, 0, 0), (0, 0, 0), (0, 0, 40 * k))
          for k in range(3)],
        _sample(120, LED2, (0, 0, 20), cue=B),
        _sample(140, LED2, (0, 0, 40), cue=B),
    ]
