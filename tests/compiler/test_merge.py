"""merge.py, the general merge of one tick's writes: what shares a frame, the longest frame,
when a gap is filled (strictly cheaper only), which cue a mixed frame belongs to, and the
cached plans (planned once per address set, planned afresh when a tick's sizes differ).
"""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from xgo_show.compiler.frames import Write
from xgo_show.compiler.layout import Layout
from xgo_show.compiler.merge import Merger, merge_writes
from xgo_show.errors import ProfileError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Access, Link, Profile, Register
from xgo_show.wire.xgo import MAX_DATA, decode_one, write_frame

MINI = get_profile("mini")
MINI_LAYOUT = Layout(MINI)
ACTION = MINI.register("action").address  # 0x3E
FAST = Link(115200, 0.0012)  # the XGO link: re-sending a byte or two always pays

# 250 one-byte registers at 0x00..0xF9 that may fill gaps: runs far longer than one frame.
LONG = Profile(
    "long", "xgo", "Long", FAST,
    tuple(Register(a, f"r{a}", Access.READ_WRITE, group="posture") for a in range(250)),
)
LONG_LAYOUT = Layout(LONG)


def w(address: int, data: bytes = b"\x01", order: int = 0, *, sample: bool = True,
      duration: float = 0.0) -> Write:
    return Write(address, data, origin(f"c{order}", order + 1), order, sample, duration)


def fields_of(frame: bytes) -> tuple[int, bytes]:
    """(address, data) of one whole write frame."""
    n, decoded = decode_one(frame)
    assert n == len(frame) and decoded is not None
    return decoded.address, decoded.data


# --- what shares a frame ------------------------------------------------------------------

def test_consecutive_registers_share_one_frame_in_address_order_whatever_the_input_order() -> None:
    writes = [w(0x35, b"\x03"), w(0x33, b"\x01"), w(0x34, b"\x02")]
    for perm in itertools.permutations(writes):
        (frame,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 4000, perm, {})
        assert frame.data == write_frame(0x33, b"\x01\x02\x03")
        assert frame.fields == ((0x33, b"\x01"), (0x34, b"\x02"), (0x35, b"\x03"))
        assert [x.address for x in frame.written] == [0x33, 0x34, 0x35]
        assert frame.t_us == 4000


def test_a_gap_is_filled_with_the_known_bytes_of_the_registers_in_it() -> None:
    known = {0x34: b"\x80"}
    (frame,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(0x33), w(0x35, b"\x02")], known)
    assert fields_of(frame.data) == (0x33, b"\x01\x80\x02")
    assert frame.fields == ((0x33, b"\x01"), (0x34, b"\x80"), (0x35, b"\x02"))
    assert [x.address for x in frame.written] == [0x33, 0x35]  # the filler is not a write


@pytest.mark.parametrize("known", [
    {},  # the gap register's value is not known
    {0x3D: b"\x01"},  # known, but pace (0x3D) is a setting: never re-sent to fill a gap
])
def test_a_gap_that_cannot_be_filled_splits_the_frame(known: dict[int, bytes]) -> None:
    frames = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(0x3C), w(0x3E, b"\x05", sample=False)],
                          known)
    assert [fields_of(f.data) for f in frames] == [(0x3C, b"\x01"), (0x3E, b"\x05")]


def test_fill_decisions_are_planned_with_the_known_registers() -> None:
    merger = Merger(MINI_LAYOUT, FAST, 0.0012, None)
    (plan,) = merger.plan_runs([w(0x33), w(0x35)], {0x34: b"\x00"})
    assert plan.address == 0x33 and plan.nbytes == 3 and plan.fills
    assert [s.write for s in plan.slots] == [0, None, 1] and plan.writes == (0, 1)
    (plain,) = merger.plan_runs([w(0x33), w(0x34)], {})
    assert plain.address == 0x33 and not plain.fills and plain.writes == (0, 1)


# --- when filling pays: strictly less link time than a separate frame ---------------------

# 10 bits a byte at 10240 baud: 1/1024 s a byte, exact in binary floating point.
EXACT = Link(10240, 0.0)
FOUR_BYTES = 4 / 1024  # s: a gap of this much silence makes a frame cost 12 bytes' time


def _gap_frames(gap: float, filler_bytes: int) -> int:
    writes = [w(0), w(filler_bytes + 1)]
    known = {a: b"\x07" for a in range(1, filler_bytes + 1)}
    return len(merge_writes(LONG_LAYOUT, Link(EXACT.baud, gap), gap, 0, writes, known))


def test_a_gap_is_filled_only_when_strictly_cheaper_than_a_second_frame() -> None:
    # A second frame costs its 8 framing bytes plus the gap: 12 bytes' time here.
    assert _gap_frames(FOUR_BYTES, 11) == 1
    assert _gap_frames(FOUR_BYTES, 12) == 2  # equal cost: a separate frame, not a longer one
    # The least bit more silence after a frame makes re-sending the 12 bytes the cheaper way.
    assert _gap_frames(FOUR_BYTES + 2.0 ** -40, 12) == 1
    assert _gap_frames(FOUR_BYTES + 2.0 ** -40, 13) == 2


# --- the longest frame: MAX_DATA data bytes ---------------------------------------------------

@pytest.mark.parametrize("count", [MAX_DATA - 1, MAX_DATA, MAX_DATA + 1, 249])
def test_a_consecutive_run_is_cut_at_max_data_bytes_and_no_sooner(count: int) -> None:
    writes = [w(a, bytes((a,))) for a in range(count)]
    frames = merge_writes(LONG_LAYOUT, FAST, 0.0012, 0, writes, {})
    got = [fields_of(f.data) for f in frames]
    assert [len(d) for _, d in got] == ([count] if count <= MAX_DATA else
                                        [MAX_DATA, count - MAX_DATA])
    assert b"".join(d for _, d in got) == bytes(range(count))  # every byte, in order
    assert [a for a, _ in got] == [0, MAX_DATA][:len(got)]


@pytest.mark.parametrize(("run", "frames"), [(MAX_DATA - 2, 1), (MAX_DATA - 1, 2)])
def test_filling_a_gap_never_makes_a_frame_longer_than_max_data(run: int, frames: int) -> None:
    # A run, one known register, one more write: filled when the three fit in one frame.
    writes = [*(w(a) for a in range(run)), w(run + 1)]
    got = merge_writes(LONG_LAYOUT, FAST, 0.0012, 0, writes, {run: b"\x09"})
    assert len(got) == frames
    assert all(len(fields_of(f.data)[1]) <= MAX_DATA for f in got)


def test_runs_joined_by_fillers_are_cut_at_max_data_too() -> None:
    # Writes at every other register, each gap known: one long filled run, cut when full.
    writes = [w(a, b"\x01") for a in range(0, 250, 2)]
    known = {a: b"\x02" for a in range(1, 250, 2)}
    frames = merge_writes(LONG_LAYOUT, FAST, 0.0012, 0, writes, known)
    got = [fields_of(f.data) for f in frames]
    assert all(len(d) <= MAX_DATA for _, d in got)
    assert len(got) == 2  # 249 bytes: one full frame and the rest
    assert len(got[0][1]) >= MAX_DATA - 1  # cut only when the next write no longer fits
    assert sum(f.data.count(b"\x01") for f in frames) >= 125


def test_writes_that_do_not_match_the_layout_are_refused_by_name() -> None:
    # Two bytes at the action register run past the table's end (nothing at 0x3F).
    with pytest.raises(ProfileError,
                       match=r"^mini: 2 bytes at 0x3E do not match the register layout$"):
        merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(ACTION, b"\x01\x02")], {})


# --- whose frame: lead cue, kind, action, duration --------------------------------------------

def test_a_frame_of_several_cues_belongs_to_the_earliest_authored_one_and_frames_go_in_cue_order(
) -> None:
    writes = [w(0x33, order=5), w(0x34, order=2), w(0x40, order=1), w(0x41, order=9)]
    frames = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, writes, {})
    assert [(f.order, f.origin, f.fields[0][0]) for f in frames] == [
        (1, origin("c1", 2), 0x40), (2, origin("c2", 3), 0x33)]


def test_frames_of_one_cue_go_in_address_order() -> None:
    frames = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(0x40, order=3), w(0x33, order=3)], {})
    assert [f.fields[0][0] for f in frames] == [0x33, 0x40]


def test_a_frame_with_any_write_that_is_not_a_sample_is_not_droppable() -> None:
    (mixed,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0,
                            [w(0x33), w(0x34, sample=False), w(0x35)], {})
    assert not mixed.droppable
    (samples,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(0x33), w(0x34)], {})
    assert samples.droppable and samples.duration == 0.0 and not samples.action


def test_an_action_write_marks_its_frame_and_gives_it_its_duration() -> None:
    # pace (a setting, no duration) and the action in one frame: the frame lasts the action.
    writes = [w(0x3D, sample=False), w(ACTION, b"\x0d", sample=False, duration=7.0)]
    (frame,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, writes, {}, action_address=ACTION)
    assert frame.action and frame.duration == 7.0
    (plain,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, writes, {})
    assert not plain.action  # no action register given: nothing starts an action
    # A sample at the action address (never planned, but the rule is about kind) starts nothing.
    (sampled,) = merge_writes(MINI_LAYOUT, FAST, 0.0012, 0, [w(ACTION)], {},
                              action_address=ACTION)
    assert not sampled.action


# --- cached plans ---------------------------------------------------------------------------

class CountingMerger(Merger):
    def __init__(self, layout: Layout) -> None:
        super().__init__(layout, FAST, 0.0012, None)
        self.planned = 0

    def plan_runs(self, ordered, known):  # type: ignore[no-untyped-def]
        self.planned += 1
        return super().plan_runs(ordered, known)


def test_a_merger_plans_each_address_set_once() -> None:
    merger = CountingMerger(MINI_LAYOUT)
    for tick in range(3):
        for addresses in ((0x33, 0x34), (0x40,)):
            writes = [w(a, bytes((tick,))) for a in addresses]
            frames = merger.merge(tick * 20_000, writes, {}, uniform=False)
            assert frames == merge_writes(MINI_LAYOUT, FAST, 0.0012, tick * 20_000, writes, {})
    assert merger.planned == 2
    merger.forget_plans()
    merger.merge(0, [w(0x40)], {}, uniform=False)
    assert merger.planned == 3


def test_a_tick_whose_sizes_differ_from_the_cached_plan_is_planned_afresh() -> None:
    # The same address set, with two bytes at vx this time (vx and vy): the plan made for one
    # byte does not fit, and the frames must be this tick's, not the cached plan's.
    merger = CountingMerger(MINI_LAYOUT)
    merger.merge(0, [w(0x30, b"\x01")], {}, uniform=False)
    writes = [w(0x30, b"\x05\x06", order=4)]
    (frame,) = merger.merge(20_000, writes, {}, uniform=False)
    assert frame == merge_writes(MINI_LAYOUT, FAST, 0.0012, 20_000, writes, {})[0]
    assert frame.t_us == 20_000 and fields_of(frame.data) == (0x30, b"\x05\x06")
    assert merger.planned == 2


def test_a_tick_planned_afresh_fills_its_gaps_from_the_known_bytes() -> None:
    # leg1_x and leg1_z with leg1_y known: one filled frame; then two bytes at leg1_z (and
    # leg2_x): planned afresh, the gap is filled again, from the bytes known now.
    merger = CountingMerger(MINI_LAYOUT)
    merger.merge(0, [w(0x40), w(0x42)], {0x41: b"\x11"}, uniform=False)
    writes = [w(0x40, b"\x01"), w(0x42, b"\x03\x04")]
    known = {0x41: b"\x22"}
    (frame,) = merger.merge(20_000, writes, known, uniform=False)
    assert fields_of(frame.data) == (0x40, b"\x01\x22\x03\x04")
    assert frame == merge_writes(MINI_LAYOUT, FAST, 0.0012, 20_000, writes, known)[0]
    assert merger.planned == 2


# Mini registers a show writes, by address: speed to pace, and the legs (no action).
WRITABLE = [*range(0x30, 0x3E), *range(0x40, 0x4C)]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sets(st.sampled_from(WRITABLE), min_size=1, max_size=8),
                          st.integers(0, 255), st.integers(0, 3)), min_size=1, max_size=6),
       st.sets(st.sampled_from([0x39, 0x3A, 0x3B, 0x3C, 0x40, 0x41]), max_size=4))
def test_cached_plans_give_the_frames_a_fresh_merge_gives(
    ticks: list[tuple[set[int], int, int]], known_addresses: set[int],
) -> None:
    known = {a: b"\x80" for a in known_addresses}
    writes_of = [[w(a, bytes(((value + a) & 0xFF,)), order=(a + shift) % 3,
                    sample=a % 2 == 0) for a in sorted(addresses)]
                 for addresses, value, shift in ticks]
    merger = Merger(MINI_LAYOUT, FAST, 0.0012, ACTION)
    for k, writes in enumerate(writes_of * 2):  # every address set again: from the cache
        if writes:
            assert merger.merge(k, writes, known, uniform=False) == merge_writes(
                MINI_LAYOUT, FAST, 0.0012, k, writes, known, action_address=ACTION)
