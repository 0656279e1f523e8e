"""Pacing: invariants on random frame sets, link-fit errors, decimation."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from xgo_show.choreo.resolved import ActionCue, MotionCue, SetCue
from xgo_show.compiler import compile_diagnostics, compile_show, state_at
from xgo_show.compiler.frames import PlannedFrame, PlannedFrames, Write
from xgo_show.compiler.pacing import Paced, pace, wire_us
from xgo_show.errors import CompileError
from xgo_show.profiles import Link, get_profile
from xgo_show.wire.xgo import write_frame

XGO = Link(115200, 0.001)


def _planned(t_us: int, nbytes: int, *, droppable: bool = False) -> PlannedFrame:
    data = write_frame(0x40, bytes(nbytes))
    w = Write(0x40, bytes(nbytes), None, 0, droppable)
    return PlannedFrame(t_us, data, ((0x40, bytes(nbytes)),), (w,), None, 0, droppable, False)


def test_wire_time_rounds_up_to_whole_microseconds() -> None:
    assert wire_us(XGO, 9) == 782  # 9 bytes * 86.805 us = 781.25 us
    assert wire_us(Link(9600, 0.001), 25) == 26042
    assert wire_us(XGO, 0) == 0
    # Exact quotients stay exact: 36 bytes at 115200 baud are 3125 us, not 3126.
    assert wire_us(XGO, 36) == 3125
    assert wire_us(SLOW, 3) == 3125


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 200_000), st.integers(1, 60)), min_size=1, max_size=60),
    st.integers(0, 3000),
    st.sampled_from([9600, 115200, 1_000_000]),
)
def test_pacing_invariants(frames: list[tuple[int, int]], gap_us: int, baud: int) -> None:
    planned = [_planned(t, n) for t, n in sorted(frames, key=lambda f: f[0])]
    link = Link(baud, gap_us / 1e6)
    result = pace(planned, link=link, gap_us=gap_us, period_us=20_000)
    starts = [p.start_us for p in result.frames]
    assert [p.frame for p in result.frames] == planned  # nothing dropped, order kept
    assert starts == sorted(starts)
    for p in result.frames:
        assert p.start_us >= p.frame.t_us  # never earlier than planned
    for a, b in zip(result.frames, result.frames[1:], strict=False):
        # spacing >= the previous frame's wire time + the gap (exact, in integer us)
        assert b.start_us - a.start_us >= wire_us(link, len(a.frame.data)) + gap_us
        spacing = (b.start_us - a.start_us) / 1e6
        assert spacing >= link.wire_time(len(a.frame.data)) + link.gap - 1e-9
        # and a frame is only late because the link was busy
        if b.start_us > b.frame.t_us:
            assert b.start_us == a.start_us + wire_us(link, len(a.frame.data)) + gap_us
    late = {(p.start_us, id(p.frame)) for p in result.late}
    for p in result.frames:
        assert ((p.start_us, id(p.frame)) in late) == (p.start_us - p.frame.t_us > 20_000)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 100_000), st.integers(1, 40), st.booleans()),
                min_size=1, max_size=80))
def test_decimation_never_drops_settings(frames: list[tuple[int, int, bool]]) -> None:
    planned = [_planned(t, n, droppable=d) for t, n, d in sorted(frames, key=lambda f: f[0])]
    result = pace(planned, link=XGO, gap_us=1000, period_us=5_000, decimate=True)
    kept = [p.frame for p in result.frames]
    assert [f for f in planned if not f.droppable] == [f for f in kept if not f.droppable]
    for p in result.frames:
        if p.frame.droppable:
            assert p.start_us - p.frame.t_us <= 2_500


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 100_000), st.integers(1, 40)), min_size=1, max_size=80))
def test_pacing_without_decimation_is_decimation_with_nothing_to_drop(
    frames: list[tuple[int, int]],
) -> None:
    # Pacing takes a shorter road without decimation; with only settings (never dropped),
    # decimation's road must start every frame at the same microsecond and find the same late.
    planned = [_planned(t, n) for t, n in sorted(frames, key=lambda f: f[0])]
    plain = pace(planned, link=XGO, gap_us=1000, period_us=5_000)
    general = pace(planned, link=XGO, gap_us=1000, period_us=5_000, decimate=True)
    assert plain.frames == general.frames and plain.late == general.late
    assert plain.dropped == general.dropped == 0


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 4_000), st.integers(1, 40)), min_size=2, max_size=60),
       st.integers(0, 1))
def test_frames_spaced_wider_than_the_longest_start_when_planned(
    frames: list[tuple[int, int]], closer: int,
) -> None:
    # One frame a tick (a 4 ms tick here, and the longest frame's 3.8 ms of wire time plus
    # gap), as most performers send: pacing's short road leaves every frame on time. One
    # frame a microsecond closer than that to the one before takes the loop: the same
    # starts as decimation's road either way.
    longest = max(n for _, n in frames)
    room = wire_us(XGO, len(write_frame(0x40, bytes(longest)))) + 1000
    times = [sum(room + extra for extra, _ in frames[:i + 1]) for i in range(len(frames))]
    if closer:
        times[-1] = times[-2] + room - 1
    planned = [_planned(t, n) for t, (_, n) in zip(times, frames, strict=True)]
    plain = pace(planned, link=XGO, gap_us=1000, period_us=5_000)
    general = pace(planned, link=XGO, gap_us=1000, period_us=5_000, decimate=True)
    assert plain.frames == general.frames and plain.late == general.late
    if not closer:
        assert plain.starts == times


def _crowded(make_show, o, **settings):  # type: ignore[no-untyped-def]
    # body_z (0x35) and servo_11 (0x50) are too far apart to share a frame: two frames per
    # tick of ~1.8 ms each, while a 500 Hz tick is 2 ms: the backlog grows every tick.
    return make_show({"rex": ("mini", [
        SetCue(0.0, o("setup", 2), {"gait": "walk"}),
        MotionCue(0.0, o("sway", 3), {"body_z": 120.0, "servo_11": 50.0}, duration=3.0),
        ActionCue(3.5, o("dance", 4), 23, "dance", 6.0),
    ])}, control_rate=500.0, **settings)


def test_track_that_does_not_fit_is_an_error_naming_time_and_cue(make_show, o) -> None:  # type: ignore[no-untyped-def]
    try:
        compile_show(_crowded(make_show, o))
    except CompileError as err:
        (diag,) = err.diagnostics
        assert diag.origin == o("sway", 3)
        assert "link does not fit cue 'sway'" in diag.message
        assert "planned at 0." in diag.message and "more than one control period (2 ms)" in \
            diag.message
        assert "decimate" in diag.message
    else:
        raise AssertionError("expected a link-fit error")



def test_validate_road_finds_the_same_link_fit_error(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # compile_diagnostics keeps no frames: the same error, with the same diagnostics.
    with pytest.raises(CompileError) as full:
        compile_show(_crowded(make_show, o))
    with pytest.raises(CompileError) as light:
        compile_diagnostics(_crowded(make_show, o))
    assert light.value.diagnostics == full.value.diagnostics
    assert str(light.value) == str(full.value)


def test_decimation_drops_samples_with_a_warning_and_still_arrives(make_show, o) -> None:  # type: ignore[no-untyped-def]
    schedule = compile_show(_crowded(make_show, o, decimate=True))
    (warning,) = schedule.warnings
    assert warning.severity == "warning" and "decimated" in warning.message
    assert compile_diagnostics(_crowded(make_show, o, decimate=True)) == schedule.warnings
    assert warning.origin == o("sway", 3)  # the cue whose samples were dropped first: file:line
    perf = schedule.performers[0]
    labels = [f.label for f in perf.frames]
    assert "gait=walk" in labels and "action=23(dance)" in labels  # never dropped
    mini = get_profile("mini")
    state = state_at(perf, 3.4)
    assert state["body_z"] == bytes((mini.register("body_z").to_byte(120.0),))
    assert state["servo_11"] == bytes((mini.register("servo_11").to_byte(50.0),))
    starts = [round(f.t * 1e6) for f in perf.frames]
    for a, b, f in zip(starts, starts[1:], perf.frames, strict=False):
        assert b - a >= wire_us(perf.link, len(f.data)) + 1000


def test_show_gap_overrides_profile_gap(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"gait": "walk", "pace": "fast"})])},
                     gap=0.004)
    perf = compile_show(show).performers[0]
    assert perf.link.gap == 0.004
    assert [round(f.t * 1e6) for f in perf.frames] == [0, 782 + 4000]


def _sample_frame(t_us: int, address: int, value: int) -> PlannedFrame:
    data = bytes((value,))
    w = Write(address, data, None, 0, True)
    return PlannedFrame(t_us, write_frame(address, data), ((address, data),), (w,), None, 0,
                        True, False)


def _remerge(t_us: int, writes: list[Write]) -> list[PlannedFrame]:
    return [_sample_frame(t_us, w.address, w.data[0]) for w in writes]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0x40, 0x43), st.integers(0, 255)),
                min_size=1, max_size=120))
def test_decimated_values_still_arrive(samples: list[tuple[int, int, int]]) -> None:
    # Samples on a 2 ms grid, far more than the link carries: many are dropped, but replaying
    # what is sent must leave every register at its last planned value.
    planned = [_sample_frame(tick * 2000, a, v) for tick, a, v in sorted(samples,
                                                                         key=lambda s: s[0])]
    result = pace(planned, link=XGO, gap_us=1000, period_us=2000, decimate=True,
                  remerge=_remerge)
    final_planned = {f.fields[0][0]: f.fields[0][1] for f in planned}
    final_sent = {p.frame.fields[0][0]: p.frame.fields[0][1] for p in result.frames}
    assert final_sent == final_planned
    starts = [p.start_us for p in result.frames]
    assert starts == sorted(starts)


# --- decimation: when values arrive, and what is dropped -------------------------------------

ONE_BYTE_US = wire_us(XGO, 9) + 1000  # a one-byte write frame and the silence after it


def _counted_remerge() -> tuple[list[int], object]:
    calls: list[int] = []

    def remerge(t_us: int, writes: list[Write]) -> list[PlannedFrame]:
        calls.append(t_us)
        return _remerge(t_us, writes)

    return calls, remerge


@settings(max_examples=100, deadline=None)
@given(st.integers(2, 12), st.integers(2_000, 20_000), st.integers(1, 9))
def test_a_burst_goes_out_one_period_at_a_time_not_at_the_end(
    burst: int, period_us: int, quiet_periods: int,
) -> None:
    # A burst of samples to ``burst`` registers at t=0, more than one period of the link can
    # carry, then a long quiet run of a single other register once every ``quiet_periods``.
    # The values dropped from the burst must be re-sent at the next period boundaries, each as
    # soon as the link has room, long before the show ends.
    planned = [_sample_frame(0, 0x40 + i, i) for i in range(burst)]
    end_us = 400 * period_us
    # (the quiet run leaves the link free for most periods: values can only go out when it has
    # room)
    every = period_us * (burst + quiet_periods)
    planned += [_sample_frame(t, 0x60, 1) for t in range(every, end_us, every)]
    calls, remerge = _counted_remerge()
    result = pace(planned, link=XGO, gap_us=1000, period_us=period_us, decimate=True,
                  remerge=remerge)  # type: ignore[arg-type]
    first_sent = {}
    for p in result.frames:
        first_sent.setdefault(p.frame.fields[0][0], p)
    for i in range(burst):
        sent = first_sent[0x40 + i]
        # Every burst value is out within as many periods as there are values before it.
        assert sent.start_us <= (i + 1) * period_us, (i, sent.start_us)
        # A re-send is planned at a period boundary after the burst and starts on it or
        # after the frame in front of it, never before.
        assert sent.frame.t_us % period_us == 0 and sent.start_us >= sent.frame.t_us
    # Only planned frames count as dropped (a re-send dropped again is not a second loss),
    # and the first drop is the first planned frame left out.
    sent_ids = {id(p.frame) for p in result.frames}
    missing = [f for f in planned if id(f) not in sent_ids]
    assert result.dropped == len(missing)
    assert result.first_drop_us == (missing[0].t_us if missing else None)
    # Re-sends are batched at most once a period (each batch is one call of the merger).
    assert all(b - a >= period_us for a, b in itertools.pairwise(calls))


def test_pacing_decimates_only_when_asked() -> None:
    # Late samples are sent late, not dropped, unless the show allows decimation.
    planned = [_sample_frame(0, 0x40 + a, a) for a in range(5)]
    result = pace(planned, link=XGO, gap_us=1000, period_us=2000, remerge=_remerge)
    assert [p.frame for p in result.frames] == planned and result.dropped == 0
    assert [p.frame for p in result.late] == planned[2:]  # more than a period behind


def test_a_fresh_sample_supersedes_a_resend_due_at_the_same_microsecond() -> None:
    # B=1 is dropped at t=0 and due again at t=2000, where B=2 is planned: B=2 goes out at
    # its time and B=1, stale by then, never does.
    a1, b1, b2 = _sample_frame(0, 0x40, 1), _sample_frame(0, 0x41, 1), _sample_frame(2000, 0x41, 2)
    result = pace([a1, b1, b2], link=XGO, gap_us=1000, period_us=2000, decimate=True,
                  remerge=_remerge)
    assert [(p.start_us, p.frame) for p in result.frames] == [(0, a1), (2000, b2)]
    assert result.dropped == 1


def test_a_long_decimated_burst_compiles_in_time_linear_in_its_length() -> None:
    # 200 ticks, each with more samples than a tick can carry: pending values are re-sent at
    # most once a tick, so the merger runs at most once per tick (not once per dropped frame,
    # which grows without bound as re-sends are dropped in their turn).
    ticks, period_us = 200, 2000
    planned = [_sample_frame(t * period_us, 0x40 + a, (t + a) % 256)
               for t in range(ticks) for a in range(4)]
    calls, remerge = _counted_remerge()
    result = pace(planned, link=XGO, gap_us=1000, period_us=period_us, decimate=True,
                  remerge=remerge)  # type: ignore[arg-type]
    assert result.dropped > ticks
    assert len(calls) <= ticks + 4
    assert len(result.frames) <= ticks + 4 + len(calls)


SLOW = Link(9600, 0.001)  # ~1 ms a byte: one frame can keep the link busy for many periods


def _busy_for(us: int) -> tuple[PlannedFrame, int]:
    """A setting at t=0 that keeps ``SLOW`` busy for more than ``us``, and when it is free."""
    first = _planned(0, us * SLOW.baud // SLOW.bits_per_byte // 1_000_000 + 1)
    return first, wire_us(SLOW, len(first.data)) + 1000


@settings(max_examples=60, deadline=None)
@given(st.integers(4, 40_000))
def test_a_sample_is_dropped_only_when_more_than_half_a_period_late(period_us: int) -> None:
    # Both sides of the rule, odd periods included ("half" rounds down to whole microseconds).
    half = period_us // 2
    first, link_free = _busy_for(period_us)
    for late_by, dropped in ((half - 1, False), (half, False), (half + 1, True)):
        sample = _sample_frame(link_free - late_by, 0x41, 7)
        result = pace([first, sample], link=SLOW, gap_us=1000, period_us=period_us,
                      decimate=True)
        assert result.dropped == int(dropped), (late_by, half)
        if dropped:
            assert [p.frame for p in result.frames] == [first]
            assert (result.first_drop_us, result.first_drop_origin) == (sample.t_us, None)
        else:
            assert result.frames[1] == (link_free, sample)
            assert result.first_drop_us is None


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 40_000), st.booleans())
def test_a_frame_exactly_one_period_late_fits_the_link(period_us: int, decimate: bool) -> None:
    # The link-fit rule from both sides: one period late fits, one microsecond more does not.
    # Settings are never dropped, so decimation must not change the verdict.
    first, link_free = _busy_for(period_us + 1)
    for late_by, late in ((period_us - 1, False), (period_us, False), (period_us + 1, True)):
        second = _planned(link_free - late_by, 1)
        result = pace([first, second], link=SLOW, gap_us=1000, period_us=period_us,
                      decimate=decimate)
        assert [p.frame for p in result.frames] == [first, second]
        assert result.frames[1].start_us - second.t_us == late_by
        assert [p.frame for p in result.late] == ([second] if late else []), (late_by, period_us)


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 40_000))
def test_only_frames_more_than_a_period_late_are_late_beside_one_that_is(period_us: int) -> None:
    # A frame exactly one period late fits even when a later one does not (the late list is
    # made only when some frame is over; each frame is judged on its own then).
    first, link_free = _busy_for(period_us + 1)
    second = _planned(link_free - period_us, 1)
    third = _planned(second.t_us + 1, 1)
    result = pace([first, second, third], link=SLOW, gap_us=1000, period_us=period_us)
    assert result.frames[1].start_us - second.t_us == period_us
    assert [p.frame for p in result.late] == [third]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 3), st.integers(0, 255)),
                min_size=1, max_size=120),
       st.integers(0, 1999))
def test_resends_never_go_out_before_planned_frames(
    samples: list[tuple[int, int, int]], phase_us: int,
) -> None:
    # Frames go out in the order they were planned for; a re-send planned for the same
    # microsecond as a planned frame goes after it (the planned value is the fresher one).
    # ``phase_us`` moves the samples off the period grid, or onto it (0).
    planned = [_sample_frame(tick * 2000 + phase_us, 0x40 + a, v)
               for tick, a, v in sorted(samples, key=lambda s: s[0])]
    result = pace(planned, link=XGO, gap_us=1000, period_us=2000, decimate=True,
                  remerge=_remerge)
    ids = {id(f) for f in planned}
    order = [(p.frame.t_us, id(p.frame) not in ids) for p in result.frames]
    assert order == sorted(order)
    # A re-send carries the newest value planned for its register up to its own microsecond,
    # never one a planned frame of that microsecond already replaced.
    for p in result.frames:
        if id(p.frame) not in ids:
            (address, value), = p.frame.fields
            newest = [f.fields[0][1] for f in planned
                      if f.fields[0][0] == address and f.t_us <= p.frame.t_us][-1]
            assert value == newest, (p.frame.t_us, address)
    # And replaying the wire leaves every register at its last planned value.
    final = {f.fields[0][0]: f.fields[0][1] for f in planned}
    assert {p.frame.fields[0][0]: p.frame.fields[0][1] for p in result.frames} == final


A = origin("a")


def test_pacing_reads_planned_frames_columns_and_names_late_frames_as_a_list_s() -> None:
    frames = PlannedFrames([_planned(0, 32)])  # 40 bytes on the wire: 41,667 us at 9600 baud
    frames.add_run([1_000, 2_000, 90_000], [b"12345678", b"abcdefgh", b"ABCDEFGH"], A, 5)
    result = pace(frames, link=SLOW, gap_us=1000, period_us=20_000)
    plain = pace(list(frames), link=SLOW, gap_us=1000, period_us=20_000)
    assert result.sent is frames and result.starts == plain.starts
    assert result.starts == [0, 42_667, 52_001, 90_000]
    assert result.late == plain.late == [
        Paced(42_667, PlannedFrame(1_000, b"12345678", (), (), A, 5, True, False, 0.0)),
        Paced(52_001, PlannedFrame(2_000, b"abcdefgh", (), (), A, 5, True, False, 0.0)),
    ]


def test_planned_frames_a_tick_apart_start_when_planned() -> None:
    frames = PlannedFrames()
    frames.add_run([0, 20_000, 40_000], [b"a", b"b", b"c"], A, 0)
    result = pace(frames, link=SLOW, gap_us=1000, period_us=20_000)
    assert result.starts == [0, 20_000, 40_000] and result.late == []
