"""PlannedFrames: a performer's planned frames as columns, read as the frames they stand for.

The fast path adds sample frames as columns (time, bytes, cue) and the general merger's frames
whole; read as a sequence, they must be the very frames a list of PlannedFrame would hold
(test_pacing: pacing paces them as it paces that list).
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.compiler.conftest import examples
from tests.compiler.conftest import origin as o
from xgo_show.compiler.frames import PlannedFrame, PlannedFrames, Write

A, B = o("a", 1), o("b", 2)
SET = Write(0x20, b"\x05", A, 0, False)
ACTION = PlannedFrame(40_000, b"\x55\x00\x09\x03\x3e\x02\xb3\x00\xaa", ((0x3E, b"\x02"),),
                      (Write(0x3E, b"\x02", B, 3, False, 1.5),), B, 3, False, True, 1.5)
SETTING = PlannedFrame(0, b"set", ((0x20, b"\x05"),), (SET,), A, 0, False, False)


def _sample(t_us: int, data: bytes, origin: object, order: int) -> PlannedFrame:
    """A sample frame as the fast path planned it before it made columns."""
    return PlannedFrame(t_us, data, (), (), origin, order, True, False, 0.0)  # type: ignore[arg-type]


def test_an_empty_one_reads_as_no_frames() -> None:
    frames = PlannedFrames()
    assert len(frames) == 0 and list(frames) == [] and frames.durations() == []
    assert frames == [] and frames == () and frames[:] == []
    with pytest.raises(IndexError):
        frames[0]


def test_frames_added_whole_are_kept_as_they_are_and_in_the_columns() -> None:
    frames = PlannedFrames([SETTING, ACTION])
    assert frames[0] is SETTING and frames[1] is ACTION and frames[-1] is ACTION
    assert frames.t_us == [0, 40_000] and frames.data == [b"set", ACTION.data]
    assert frames.origins == [A, B] and frames.orders == [0, 3]
    assert frames.whole == {0: SETTING, 1: ACTION}
    assert frames.durations() == [0.0, 1.5]


def test_sample_frames_are_made_when_read() -> None:
    frames = PlannedFrames()
    frames.add_run([20_000, 40_000], [b"x1", b"x2"], A, 4)
    frames.add_samples([60_000, 60_000], [b"y1", b"y2"], [B, None], [7, 2])
    assert frames.t_us == [20_000, 40_000, 60_000, 60_000]
    assert frames.data == [b"x1", b"x2", b"y1", b"y2"]
    assert frames.origins == [A, A, B, None] and frames.orders == [4, 4, 7, 2]
    assert frames.whole == {} and frames.durations() == [0.0] * 4
    assert list(frames) == [
        PlannedFrame(20_000, b"x1", (), (), A, 4, True, False, 0.0),
        PlannedFrame(40_000, b"x2", (), (), A, 4, True, False, 0.0),
        PlannedFrame(60_000, b"y1", (), (), B, 7, True, False, 0.0),
        PlannedFrame(60_000, b"y2", (), (), None, 2, True, False, 0.0),
    ]
    assert frames[-2] == PlannedFrame(60_000, b"y1", (), (), B, 7, True, False, 0.0)
    assert frames[1:3] == [frames[1], frames[2]] and frames[::-2] == [frames[3], frames[1]]
    with pytest.raises(IndexError):
        frames[4]
    with pytest.raises(IndexError):
        frames[-5]


def test_whole_frames_keep_their_place_among_sample_frames() -> None:
    frames = PlannedFrames()
    frames.add_run([0], [b"s0"], A, 1)
    frames.extend([SETTING])
    frames.add_run([20_000, 20_000], [b"s2", b"s3"], B, 2)
    frames.extend(iter([ACTION]))  # any iterable
    assert frames.whole == {1: SETTING, 4: ACTION}
    assert frames[1] is SETTING and frames[4] is ACTION
    assert frames.durations() == [0.0, 0.0, 0.0, 0.0, 1.5]
    assert frames.t_us == [0, 0, 20_000, 20_000, 40_000]
    assert frames.orders == [1, 0, 2, 2, 3]
    assert [f.droppable for f in frames] == [True, False, True, True, False]


@pytest.mark.parametrize("lengths", [(1, 2, 2, 2), (2, 1, 2, 2), (2, 2, 1, 2), (2, 2, 2, 1)])
def test_columns_of_different_lengths_are_refused(lengths: tuple[int, int, int, int]) -> None:
    times, data, origins, orders = ([v] * n for v, n in zip((0, b"d", A, 0), lengths,
                                                             strict=True))
    frames = PlannedFrames()
    with pytest.raises(ValueError, match=r"^sample frame columns of different lengths$"):
        frames.add_samples(times, data, origins, orders)  # type: ignore[arg-type]
    assert len(frames) == 0 and frames.origins == [] and frames.orders == []


def test_a_run_of_one_cue_needs_as_many_bytes_as_times() -> None:
    with pytest.raises(ValueError, match="different lengths"):
        PlannedFrames().add_run([0, 20_000], [b"d"], A, 0)


def test_of_keeps_planned_frames_and_reads_a_list_off_its_frames() -> None:
    frames = PlannedFrames([SETTING])
    assert PlannedFrames.of(frames) is frames
    made = PlannedFrames.of([SETTING, ACTION])
    assert isinstance(made, PlannedFrames) and made.whole == {0: SETTING, 1: ACTION}
    assert made.t_us == [0, 40_000] and made.durations() == [0.0, 1.5]
    assert PlannedFrames.of(()) == []


def test_equality_is_a_list_s() -> None:
    frames = PlannedFrames([SETTING])
    frames.add_run([20_000], [b"x"], A, 0)
    same = [SETTING, _sample(20_000, b"x", A, 0)]
    assert frames == same and frames == tuple(same) and frames == PlannedFrames.of(same)
    assert frames != same[:1] and frames != [*same, SETTING] and frames != [ACTION, same[1]]
    assert frames != PlannedFrames() and (frames == "x") is False
    assert frames.__eq__(3) is NotImplemented
    with pytest.raises(TypeError):
        hash(frames)
    assert repr(frames) == f"PlannedFrames({same!r})"


OPS = st.lists(st.one_of(
    st.tuples(st.just("whole"), st.lists(st.sampled_from([SETTING, ACTION]), max_size=3)),
    st.tuples(st.just("run"), st.lists(st.binary(min_size=1, max_size=4), max_size=4),
              st.sampled_from([A, B, None]), st.integers(0, 9)),
    st.tuples(st.just("samples"),
              st.lists(st.tuples(st.binary(min_size=1, max_size=4), st.sampled_from([A, None]),
                                 st.integers(0, 9)), max_size=4)),
), max_size=8)


@settings(max_examples=examples(200), deadline=None)
@given(OPS)
def test_columns_read_as_the_list_of_frames_they_stand_for(ops: list[tuple]) -> None:  # type: ignore[type-arg]
    frames, plain = PlannedFrames(), []
    t = 0
    for op in ops:
        if op[0] == "whole":
            frames.extend(op[1])
            plain += op[1]
        elif op[0] == "run":
            _, data, origin, order = op
            times = list(range(t, t + len(data)))
            frames.add_run(times, data, origin, order)
            plain += [_sample(ti, d, origin, order) for ti, d in zip(times, data, strict=True)]
        else:
            rows = op[1]
            times = [t] * len(rows)
            frames.add_samples(times, [r[0] for r in rows], [r[1] for r in rows],
                               [r[2] for r in rows])
            plain += [_sample(t, d, origin, order) for d, origin, order in rows]
        t += 10
    assert list(frames) == plain and frames == plain and len(frames) == len(plain)
    assert [frames[i] for i in range(-len(plain), len(plain))] == plain + plain
    assert frames.t_us == [f.t_us for f in plain] and frames.data == [f.data for f in plain]
    assert frames.origins == [f.origin for f in plain]
    assert frames.orders == [f.order for f in plain]
    assert frames.durations() == [f.duration for f in plain]
