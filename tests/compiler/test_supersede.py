"""Where one move or fade hands over to the next on the same registers, the planner files the
next one's sample in the last one's place (``planner._supersedes``) instead of mixing the two
as Writes (the plain road): the tick stays one of samples, made into frames on the fast road
with the ticks after it. Both roads must give the same frames, byte for byte, at the same
times, filed under the same cues.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from tests.compiler.test_fast_path import chained_tracks, tracks
from xgo_show.choreo.resolved import FadeCue, MotionCue, ResolvedTrack
from xgo_show.compiler.fastpath import frames_from_ticks
from xgo_show.compiler.planner import XgoPlanner, _supersedes
from xgo_show.compiler.sources import Samples, Source
from xgo_show.compiler.state import layout_of
from xgo_show.profiles import get_profile


class _Plain(XgoPlanner):
    supersede = False


def _road(track: ResolvedTrack, planner_class: type[XgoPlanner], *, details: bool
          ) -> tuple[XgoPlanner, list[tuple[object, ...]], int]:
    """The planner after planning ``track``, its frames (what each is) and how many hold
    samples only."""
    profile = get_profile(track.model)
    layout = layout_of(profile)
    planner = planner_class(layout, track, 50.0)
    planner.plan()
    frames, samples = frames_from_ticks(layout, profile.link, profile.link.gap, planner.ticks,
                                        planner.mixed, planner.action_reg, details)
    # Which fields a frame holds and what it was asked to write are kept with details alone
    # (the fast road leaves them out of sample frames: pacing reads them only to decimate).
    return planner, [(f.t_us, f.data, f.origin, f.order, f.droppable, f.action, f.duration,
                      *((f.fields, f.written) if details else ())) for f in frames], samples


@settings(max_examples=150, deadline=None)
@given(st.one_of(tracks(), chained_tracks()), st.booleans())
def test_superseding_gives_the_frames_of_the_plain_road(track: ResolvedTrack,
                                                        details: bool) -> None:
    plain, plain_frames, plain_samples = _road(track, _Plain, details=details)
    planner, frames, samples = _road(track, XgoPlanner, details=details)
    assert frames == plain_frames
    assert samples == plain_samples
    assert planner.diag.items == plain.diag.items
    assert planner.end == plain.end
    assert planner.mixed <= plain.mixed


def test_hand_overs_in_a_chain_stay_sample_ticks() -> None:
    # The compile_speed benchmark's shape: each move starts where the one before ends, on the
    # tick grid, a Rider's two LEDs fading beside it (one led: cue, a fade per LED).
    cues = []
    for n in range(4):
        o = origin(f"c{n}", n + 1)
        cues += [MotionCue(2.0 * n, o, {"body_z": 80.0 + 20 * (n % 2), "roll": 4.0 - 8 * (n % 2)},
                           2.0),
                 FadeCue(2.0 * n, o, "led1", (40 * n, 0, 255 - 40 * n), 2.0),
                 FadeCue(2.0 * n, o, "led2", (0, 40 * n, 9), 2.0)]
    track = ResolvedTrack("p", "rider", tuple(cues))
    plain, plain_frames, _ = _road(track, _Plain, details=False)
    planner, frames, _ = _road(track, XgoPlanner, details=False)
    assert planner.diag.items == []
    assert frames == plain_frames
    assert len(plain.mixed) == 3  # each hand-over, mixed on the plain road
    assert planner.mixed == set()
    # Every tick one source's sample or several sources' (a Samples), none Writes.
    assert all(isinstance(entry, tuple | Samples) for entry in planner.ticks.values())


def test_a_sample_supersedes_only_a_no_later_cue_s_on_no_more_registers() -> None:
    layout = layout_of(get_profile("mini"))
    body_z, roll, yaw = (layout.register(name) for name in ("body_z", "roll", "yaw"))
    o = origin("c")
    earlier = Source((body_z, roll), o, 3)
    assert _supersedes(Source((body_z, roll), o, 4), earlier)
    assert _supersedes(Source((body_z, roll, yaw), o, 3), earlier)  # more registers
    assert not _supersedes(Source((body_z, roll), o, 2), earlier)  # an earlier cue
    assert not _supersedes(Source((body_z, yaw), o, 4), earlier)  # roll would be left
