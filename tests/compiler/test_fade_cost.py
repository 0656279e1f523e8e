"""An LED fade costs what it sends: the ticks where its colour changes, not time x rate."""

from __future__ import annotations

import time

from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import FadeCue, ResolvedShow, ResolvedTrack
from xgo_show.compiler import compile_show
from xgo_show.compiler.frames import first_tick
from xgo_show.diagnostics import Origin
from xgo_show.wire.xgo import decode_one

ORIGIN = Origin("s.yaml", 1, 1, "fade")


def _fade_frames(fade: FadeCue, rate: float) -> list[tuple[float, bytes]]:
    show = ResolvedShow("t", "s.yaml", (ResolvedTrack("rex", "rider", (fade,)),),
                        control_rate=rate)
    out = []
    for f in compile_show(show).performers[0].frames:
        _, frame = decode_one(f.data)
        assert frame is not None
        out.append((f.t, frame.data))
    return out


def test_an_hour_long_fade_at_1000_hz_compiles_in_a_moment() -> None:
    started = time.monotonic()
    frames = _fade_frames(FadeCue(0.0, ORIGIN, "led1", (255, 128, 3), 3600.0), 1000.0)
    assert time.monotonic() - started < 3.0  # was minutes: 3.6 million ticks sampled
    assert len(frames) <= 255 + 128 + 3 + 2


@settings(max_examples=80, deadline=None)
# Wide fades change colour about every tick (sampled tick by tick), narrow ones hold each
# colour for a while (sampled by galloping over the runs): both ways are compared.
@given(to=st.one_of(st.tuples(*[st.integers(0, 255)] * 3), st.tuples(*[st.integers(0, 9)] * 3)),
       start=st.floats(0, 2),
       duration=st.floats(0.5, 3), rate=st.sampled_from([10.0, 37.5, 50.0, 100.0]))
def test_fade_frames_are_the_colour_changes_of_every_tick(
        to: tuple[int, int, int], start: float, duration: float, rate: float) -> None:
    """Reference: the colour at every tick (the naive sampling), keeping each change."""
    frames = _fade_frames(FadeCue(start, ORIGIN, "led1", to, duration), rate)
    expected: list[bytes] = []
    k = first_tick(start, rate)  # the compiler's own grid rule (start=1e-9 at 10 Hz: tick 1)
    while round(k * 1_000_000 / rate) < round((start + duration) * 1_000_000):
        frac = min(max((k / rate - start) / duration, 0.0), 1.0)
        colour = bytes(round(c * frac) for c in to)
        if not expected or colour != expected[-1]:
            expected.append(colour)
        k += 1
    if not expected or expected[-1] != bytes(to):
        expected.append(bytes(to))
    assert [data[-3:] for _, data in frames] == expected
