"""Frames: exact bytes of merged writes, gap filling, de-duplication, actions, fades, labels."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, describe_frame
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.sim.xgo_robot import XgoRobot

BEAT_132 = 60 / 132  # a beat at 132 bpm: 0.4545... s, off the 20 ms tick grid


def _frames(show):  # type: ignore[no-untyped-def]
    return compile_show(show).performers[0].frames


def test_adjacent_registers_merge_into_one_frame_golden(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("pose"), {"body_x": 0.0, "body_y": 19.5, "body_z": 120.0}),
    ])})
    (frame,) = _frames(show)
    assert frame.data == bytes([
        0x55, 0x00,  # header
        0x0B,        # length: the whole frame, 8 + 3 data bytes
        0x00,        # type: write (Mini/Lite)
        0x33,        # address: body_x, first of three consecutive registers
        0x80,        # body_x 0 mm -> neutral 0x80
        0xFF,        # body_y 19.5 mm (its maximum)
        0xFF,        # body_z 120 mm (its maximum)
        0x43,        # checksum: ~(0x0B + 0x00 + 0x33 + 0x80 + 0xFF + 0xFF) & 0xFF
        0x00, 0xAA,  # tail
    ])
    assert frame.label == "body_x=0.0mm body_y=19.5mm body_z=120.0mm"
    assert frame.origin == o("pose")
    assert frame.t == 0.0


def test_rider_leds_merge_with_rider_write_type_golden(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        SetCue(1.5, o("lights"), {"led1": (255, 0, 16), "led2": (1, 2, 3)}),
    ])})
    (frame,) = _frames(show)
    assert frame.data == bytes([
        0x55, 0x00,  # header
        0x0E,        # length: 8 + 6 data bytes
        0x01,        # type: write as the Rider's vendor library sends it
        0x69,        # address: led1; the 6 bytes walk led1 (0x69) then led2 (0x6A)
        0xFF, 0x00, 0x10,  # led1 r, g, b
        0x01, 0x02, 0x03,  # led2 r, g, b
        0x72,        # checksum: ~(0x0E + 0x01 + 0x69 + 0xFF + 0x00 + 0x10 + 1 + 2 + 3) & 0xFF
        0x00, 0xAA,  # tail
    ])
    assert frame.label == "led1=#FF0010 led2=#010203"
    assert frame.t == 1.5


def test_small_gap_is_bridged_with_bytes_the_register_already_holds(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # body_z (0x35) and pitch (0x37): roll (0x36) in between still holds its initial 0x80,
    # re-sending that one byte is cheaper than a second 8-byte frame plus 1 ms of silence.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"body_z": 75.0, "pitch": 22.0})])})
    (frame,) = _frames(show)
    assert frame.data[3:8] == bytes([0x00, 0x35, 0x00, 0x80, 0xFF])
    assert frame.label == "body_z=75.0mm roll=0.0deg pitch=22.0deg"


def test_gap_over_a_setting_or_hole_is_not_bridged(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # mark_time 0x3C and action 0x3E: pace 0x3D between them is a setting, never re-sent;
    # mark_time and gripper 0x71 are far apart, with unmapped addresses in between.
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("s"), {"mark_time": 20.0, "gripper": 50.0}),
        ActionCue(0.0, o("a"), 23, "dance", 6.0),
    ])})
    frames = _frames(show)
    assert [f.data[4] for f in frames] == [0x3C, 0x71, 0x3E]
    assert all(len(f.data) == 9 for f in frames)


def test_gap_is_bridged_while_cheaper_than_a_frame(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # vx 0x30 .. mark_time 0x3C: 11 state registers in between. At 115200 baud 11 bytes take
    # 955 us; a separate frame costs 8 bytes (694 us) + 1 ms of silence, so bridging wins.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"vx": 5.0, "mark_time": 20.0})])})
    (frame,) = _frames(show)
    assert frame.data[4] == 0x30 and len(frame.data) == 8 + 13
    # With 0.1 ms of silence a frame costs only 794 us: bridging 955 us no longer pays.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"vx": 5.0, "mark_time": 20.0})])},
                     gap=0.0001)
    assert [len(f.data) for f in _frames(show)] == [9, 9]


def test_unchanged_samples_are_dropped(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("slow"), {"body_z": 100.0}, duration=4.0),
    ])})
    frames = _frames(show)
    values = [f.data[5] for f in frames]
    assert all(a != b for a, b in itertools.pairwise(values))
    # 4 s at 50 Hz would be 201 samples; the byte changes far fewer times
    assert len(frames) < 60
    assert values[-1] == get_profile("mini").register("body_z").to_byte(100.0)


def test_settings_and_actions_are_always_sent(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("g1"), {"gait": "walk"}),
        SetCue(1.0, o("g2"), {"gait": "walk"}),
        ActionCue(2.0, o("d1"), 23, "dance", 6.0),
        ActionCue(8.0, o("d2"), 23, "dance", 6.0),
    ])})
    frames = _frames(show)
    assert [f.label for f in frames] == ["gait=walk", "gait=walk", "action=23(dance)",
                                         "action=23(dance)"]
    assert [f.duration for f in frames] == [0.0, 0.0, 6.0, 6.0]


def test_samples_sit_on_the_tick_grid_and_settings_at_their_start(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.013, o("m"), {"roll": 10.0}, duration=1.0),
        SetCue(2.345, o("s"), {"pace": "fast"}),
    ])}, control_rate=40.0)
    frames = _frames(show)
    samples = [f for f in frames if f.origin == o("m")]
    assert samples[0].t == pytest.approx(0.025)  # first tick at or after 0.013 s
    for f in samples[:-1]:
        assert round(f.t * 40_000_000) % 1_000_000 == 0  # a multiple of 1/40 s
    # The exact target goes out at the move's end, 1.013 s, not at the next tick (1.025 s).
    assert samples[-1].t == pytest.approx(1.013)
    assert samples[-1].data[5] == get_profile("mini").register("roll").to_byte(10.0)
    assert frames[-1].t == pytest.approx(2.345)
    assert frames[-1].label == "pace=fast"


def test_fade_steps_end_exactly_and_drop_unchanged(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("f"), "led3", (3, 0, 0), 1.0),
    ])})
    frames = _frames(show)
    colours = [dict(describe_frame(get_profile("rider"), f.data))["led3"] for f in frames]
    assert colours == [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)]


def test_reset_action_returns_posture_start_to_default(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("up"), {"body_z": 115.0}, duration=1.0),
        ActionCue(2.0, o("reset"), 255, "reset", 1.0),
        MotionCue(4.0, o("again"), {"body_z": 115.0}, duration=1.0),
    ])})
    frames = _frames(show)
    again = [f for f in frames if f.origin == o("again")]
    # The second move starts from the default height again, so it really moves.
    assert len(again) > 10
    assert again[0].label == "body_z=97.6mm"


def test_xarm_cue_is_one_servo_move_and_other_cues_are_errors(make_show, o) -> None:  # type: ignore[no-untyped-def]
    from xgo_show.errors import CompileError

    (frame,) = _frames(make_show({"arm": ("xarm", [ArmCue(0.25, o("r"), {2: 300, 1: 500}, 1.2)])}))
    assert frame.data == bytes([
        0x55, 0x55,  # header
        0x0B,        # length: itself, command and 9 parameter bytes
        0x03,        # ServoMove
        0x02,        # two servos
        0xB0, 0x04,  # 1200 ms, little-endian
        0x01, 0xF4, 0x01,  # servo 1 -> 500 (ids in ascending order)
        0x02, 0x2C, 0x01,  # servo 2 -> 300
    ])
    assert frame.t == 0.25 and frame.duration == 1.2
    assert frame.label == "time_ms=1200 servo_1=500 servo_2=300"
    with pytest.raises(CompileError) as err:
        compile_show(make_show({"arm": ("xarm", [SetCue(0.0, o("s", 7), {"gait": "walk"}),
                                                 ArmCue(1.0, o("r", 8), {9: 500}, 1.0)])}))
    messages = [d.message for d in err.value.diagnostics]
    assert messages == ["cue 's': an xArm only takes arm cues", "cue 'r': no xArm servo 9"]


def _replay(model: str, frames: tuple[ScheduledFrame, ...]) -> XgoRobot:
    """A simulated robot that received ``frames`` at their scheduled times."""
    robot = XgoRobot(get_profile(model))
    for f in frames:
        robot.receive(f.data, f.t)
    return robot


def test_move_ending_off_grid_sends_its_target_at_its_end_not_after_an_action(make_show, o) -> None:  # type: ignore[no-untyped-def]
    end = 3 * BEAT_132  # 1.3636 s: between the 50 Hz ticks at 1.36 s and 1.38 s
    show = make_show({"rex": ("mini", [
        MotionCue(BEAT_132, o("lean"), {"body_z": 110.0, "roll": 12.0}, duration=2 * BEAT_132),
        ActionCue(end, o("wave"), 13, "wave", 7.0),
    ])})
    frames = _frames(show)
    # The action's command is the last write: nothing after it cuts the action.
    assert frames[-1].origin == o("wave")
    assert all(f.t <= end + 1e-9 for f in frames[:-1])
    robot = _replay("mini", frames)
    (wave,) = robot.actions
    assert wave["interrupted_at"] is None
    # ... and the move still arrived exactly.
    mini = get_profile("mini")
    assert robot.raw("body_z")[0] == mini.register("body_z").to_byte(110.0)
    assert robot.raw("roll")[0] == mini.register("roll").to_byte(12.0)


def test_action_interrupting_a_move_stops_its_samples_at_the_action(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("rise"), {"body_z": 115.0, "pitch": 10.0}, duration=2.0),
        MotionCue(0.5, o("lean"), {"roll": -15.0}, duration=2.0),
        ActionCue(3 * BEAT_132, o("wave"), 13, "wave", 7.0, interrupts=True),
    ])})
    frames = _frames(show)
    assert frames[-1].origin == o("wave")
    assert any("roll=" in f.label for f in frames[:-1])  # lean's samples (merged with rise's)
    assert all(f.t < 3 * BEAT_132 for f in frames[:-1])
    (wave,) = _replay("mini", frames).actions
    assert wave["interrupted_at"] is None


def test_set_right_at_an_off_grid_move_end_is_not_overwritten(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("lean"), {"roll": 12.0}, duration=2 * BEAT_132),
        SetCue(2 * BEAT_132, o("level"), {"roll": -5.0}),
    ])})
    frames = _frames(show)
    assert frames[-1].origin == o("level")
    roll = get_profile("mini").register("roll")
    assert _replay("mini", frames).raw("roll")[0] == roll.to_byte(-5.0)


def test_fade_ending_off_grid_ends_at_its_end_not_over_a_set_there(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("glow"), "led1", (255, 0, 0), BEAT_132),
        SetCue(2 * BEAT_132, o("blue"), {"led1": (0, 0, 255)}),
    ])})
    glow = [f for f in _frames(show) if f.origin == o("glow")]
    assert glow[-1].t == pytest.approx(BEAT_132, abs=1e-6)  # not at the next tick, 0.46 s
    assert glow[-1].label == "led1=#FF0000"
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("glow"), "led1", (255, 0, 0), BEAT_132),
        SetCue(BEAT_132, o("blue"), {"led1": (0, 0, 255)}),
    ])})
    frames = _frames(show)
    assert frames[-1].origin == o("blue")
    assert _replay("rider", frames).raw("led1") == bytes((0, 0, 255))


def test_a_fade_cut_by_another_stops_there_and_the_next_starts_from_its_colour(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # 0 -> red over 2 s, cut at 1 s (half red, 128) by a 0.5 s fade to blue.
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("red"), "led1", (255, 0, 0), 2.0),
        FadeCue(1.0, o("blue"), "led1", (0, 0, 255), 0.5, interrupts=True),
    ])})
    frames = _frames(show)
    red = [f for f in frames if f.origin == o("red")]
    blue = [f for f in frames if f.origin == o("blue")]
    assert max(f.t for f in red) < 1.0  # nothing of the red fade after the cut
    assert blue[0].t == pytest.approx(1.0)
    assert blue[0].data[5] == 128  # blue starts from the red the first fade had reached
    assert blue[-1].t == pytest.approx(1.5) and blue[-1].label == "led1=#0000FF"
    assert _replay("rider", frames).raw("led1") == bytes((0, 0, 255))


def test_a_set_cuts_a_fade_under_way(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("red"), "led1", (255, 0, 0), 2.0),
        SetCue(1.0, o("green"), {"led1": (0, 255, 0)}, interrupts=True),
    ])})
    frames = _frames(show)
    assert max(f.t for f in frames if f.origin == o("red")) < 1.0
    assert frames[-1].origin == o("green")
    assert _replay("rider", frames).raw("led1") == bytes((0, 255, 0))


@settings(max_examples=40, deadline=None)
@given(
    start=st.integers(0, 2000).map(lambda ms: ms / 1000),
    duration=st.integers(700, 2500).map(lambda ms: ms / 1000),
    rate=st.sampled_from([25.0, 40.0, 50.0, 60.0, 100.0]),
)
def test_move_samples_lie_on_the_grid_and_the_target_lands_at_the_end(
    start: float, duration: float, rate: float
) -> None:
    from tests.compiler.conftest import origin
    from xgo_show.choreo.resolved import ResolvedShow, ResolvedTrack

    # A move, and a preset action right at its end: every write of the move goes out by then.
    cues = (
        MotionCue(start, origin("m"), {"roll": 15.0, "body_z": 80.0}, duration=duration),
        ActionCue(start + duration, origin("a"), 13, "wave", 7.0),
    )
    show = ResolvedShow("t", "t.yaml", (ResolvedTrack("rex", "mini", cues),), control_rate=rate)
    frames = compile_show(show).performers[0].frames
    assert frames[-1].origin == origin("a")
    end_us = round((start + duration) * 1e6)
    for f in frames[:-1]:
        t_us = round(f.t * 1e6)
        assert t_us <= end_us
        on_grid = t_us == round(round(t_us * rate / 1e6) * 1e6 / rate)
        assert on_grid or t_us == end_us
    robot = _replay("mini", frames)
    assert robot.actions[0]["interrupted_at"] is None
    mini = get_profile("mini")
    assert robot.raw("roll")[0] == mini.register("roll").to_byte(15.0)
    assert robot.raw("body_z")[0] == mini.register("body_z").to_byte(80.0)


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.sampled_from([50.0, 60.0, 62.5, 100.0, 25.0, 1000.0, 7.0, 1e6, 3e6, 0.5]),
                 st.integers(1, 2000).map(float), st.floats(0.1, 5000.0)),
       st.integers(0, 10**10), st.integers(-3, 400))
# 101 Hz divides 1,000,001 us, not a second: no whole-microsecond period. Past 2**53 us the
# range would be exact where round() of a float is not (10**19 + 1 is no float): round() it is.
@example(101.0, 0, 3)
@example(1e6, 10**19 + 1, 2)
def test_tick_times_are_each_ticks_time(rate: float, k0: int, count: int) -> None:
    # A range at rates of a whole-microsecond period, round() a tick otherwise: the same.
    from xgo_show.compiler.frames import tick_times, tick_us

    assert tick_times(k0, k0 + count, rate) == [tick_us(k, rate)
                                                for k in range(k0, k0 + count)]


@given(st.binary(max_size=80), st.integers(1, 9))
@example(b"\n", 1)  # a newline alone: the byte '.' skips without DOTALL
@example(b"\n\n\r\n", 2)
@example(b"ab\ncd\n", 3)
@example(b"ab\n", 2)  # a shorter rest is no row
def test_cut_rows_cuts_any_bytes_into_whole_rows_in_order(buf: bytes, width: int) -> None:
    from xgo_show.compiler.frames import cut_rows

    rows = [buf[i:i + width] for i in range(0, len(buf) - width + 1, width)]
    assert cut_rows(buf, width) == rows
    # The planner cuts a bytearray: its rows are bytes all the same.
    cut = cut_rows(bytearray(buf), width)
    assert cut == rows and all(type(row) is bytes for row in cut)


def test_cut_rows_of_every_byte_value() -> None:
    from xgo_show.compiler.frames import cut_rows

    every = bytes(range(256))
    assert cut_rows(every, 4) == [bytes((i, i + 1, i + 2, i + 3)) for i in range(0, 256, 4)]
    assert cut_rows(every, 1) == [bytes((i,)) for i in range(256)]
    assert cut_rows(every, 256) == [every] and cut_rows(every, 257) == []
    assert cut_rows(b"", 3) == []


def test_cut_rows_compiles_a_widths_pattern_once(monkeypatch: pytest.MonkeyPatch) -> None:
    import re

    from xgo_show.compiler import frames

    monkeypatch.setattr(frames, "_CUTS", {})  # the patterns made here, none from another test
    assert frames.cut_rows(b"\n\r\n\x00\n\n", 3) == [b"\n\r\n", b"\x00\n\n"]
    assert frames.cut_rows(b"abcd", 2) == [b"ab", b"cd"]
    assert sorted(frames._CUTS) == [2, 3]
    assert frames._CUTS[3].pattern == b"..." and frames._CUTS[3].flags & re.DOTALL
    # The next call of a width takes its pattern from the cache: one put there that cuts
    # single bytes shows it is used, not made again.
    frames._CUTS[3] = re.compile(b".", re.DOTALL)
    assert frames.cut_rows(b"abc", 3) == [b"a", b"b", b"c"]
